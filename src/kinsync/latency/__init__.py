"""Method A: total IMU-LiDAR latency from a sphere scanned on a rotating table."""
