"""What agents sense: the ``Sensor`` kinds (``sensor``) and the suite of every agent's
sensors (``sensor_suite``); the geometry snapshot and the compiled ray kernels behind
cameras, lidar and the top-down map; touch, proprioception, smell and hearing; noise; the
global state."""
