"""Hardware in the loop: the station's ports spoken over the robot driver's LCM messages.

``tangle_drake.station.build_station(scenario, hardware=True)`` gives the controller side (the
same ports as the simulated station, no ``sim.*``; each driver's LCM branch lives in
``tangle_drake.drivers``, what they share in ``tangle_drake.lcm_io``, the safety supervisor in
``tangle_drake.station.safety``). Here is the robot's side: ``hardware_sim.build_hardware_sim``
(what a real Nextage replaces), ``scripted`` (a controller that plays a short script to check
a station end to end) and ``loop.HardwareInTheLoop``, which runs both sides in one process
over ``memq://``. See ``docs/hardware.md`` for connecting a real robot.
"""
