"""Planning on grids: occupancy grids and costmaps (ROS costmap_2d's inflation), D* Lite with
incremental repair (seed 000, D.1), the dynamic window approach (D.3). Pure: numpy arrays in
and out, no I/O, no threads, no clock."""
