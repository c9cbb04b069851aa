"""Hardware in the loop: the station's ports spoken over the robot driver's LCM messages.

``tangle_drake.station.build_station(scenario, hardware=True)`` gives the controller side (the
same ports as the simulated station, no ``sim.*``; each driver's LCM branch lives in
``tangle_drake.drivers``); here are what those branches share (``messages``, ``lcm_systems``,
``images``, ``buses``, ``config``), the ``safety`` supervisor, ``hardware_sim.build_hardware_sim``
(the robot side that a real Nextage replaces) and ``loop.HardwareInTheLoop``, which runs both
in one process over ``memq://``. See ``docs/hardware.md`` for connecting a real robot.

This package's ``__init__`` stays import-free: the scenario schema imports ``config`` from it.
"""
