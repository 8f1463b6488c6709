"""Seed 000's navigation: the ROS parameter files it reads (``costmap_params.yaml``,
``dwa_params.yaml``, ``move_base_params.yaml``, shipped here), the overhead tracker node, the
navigator (D* Lite and DWA), and the runs of ``servolab navigate`` and ``servolab plan``."""
