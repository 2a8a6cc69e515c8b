"""ROS 2 nodes of gear_rotor_sim (rclpy). The physics core imports nothing from here.

The nodes step the model in one thread with small dense products per chunk (state transfer, output
blocks); a multi-threaded BLAS only adds thread start-up and spin-waiting to them, which on a loaded
2-core machine measured 27 ms instead of 0.013 ms for the two-stage model's state product. The BLAS
thread count therefore defaults to 1 for processes that import the nodes (an explicit
``OPENBLAS_NUM_THREADS`` / ``OMP_NUM_THREADS`` in the environment wins). This must run before NumPy is
imported, which ``gear_rotor_sim/__init__.py`` does not do.
"""

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
