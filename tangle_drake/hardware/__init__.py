"""Hardware in the loop: the station's ports spoken over the robot driver's LCM messages.

``station.build_hardware_station`` gives the controller side (the same ports as the simulated
station, no ``sim.*``), ``hardware_sim.build_hardware_sim`` the robot side that a real Nextage
replaces, and ``loop.HardwareInTheLoop`` runs both in one process over ``memq://``. See
``docs/hardware.md`` for connecting a real robot.

This package's ``__init__`` stays import-free: the scenario schema imports ``config`` from it.
"""
