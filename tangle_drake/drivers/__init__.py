"""Drivers: what turns a station port into actuation or a measurement, one module per kind.

Each module holds every branch of its kind in one place, with the same ``{model}.{port}``
names on all of them: the simulated one (Drake systems around the plant), the hardware
station's (LCM messages to and from the robot's drivers) and the robot's side of those
messages that the hardware simulator plays. Their configs are the scenario's data
(:mod:`tangle_drake.scenario.drivers`); :mod:`.registry` finds the module for a config.
"""
