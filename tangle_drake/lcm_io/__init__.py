"""What every LCM branch of the drivers shares, on the controller's and on the robot's side:
the messages and their checks (``messages``, ``images``), subscriber and publisher systems that
refuse a malformed message (``lcm_systems``), the robot side's command watchdog (``watchdog``)
and the scenario's buses (``buses``).
"""
