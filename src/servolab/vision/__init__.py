"""Vision on OpenCV: camera calibration and image-to-floor mapping (seed 000, Appendix C), and
a synthetic camera that renders what a calibrated camera would see, for tests against truth."""
