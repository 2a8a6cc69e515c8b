"""Live view without ROS: the simulator's streams on a Foxglove WebSocket server (``serve``)."""
