"""A Slamtec RPLIDAR read over its serial port (issue 29): whole revolutions as scans in
the robot's frame, for the missions' obstacle sensing and for mapping."""

# What `--lidar` means without a port: the simulator's own lidar (with --sim), or the
# settings file's port. Here, with nothing heavy beside it, for the command line's parser.
SIMULATED_LIDAR = "simulated"
