"""Picking parts one at a time: the pick state machine, its outcomes, the pick diagram, the demo.

- ``motion``: the interface the state machine uses to move a manipulator (``Motion``);
- ``planner``: ``PickPlanner``, the state machine as a Drake system;
- ``outcome``: pick outcomes and records, and the simulation-only ``LiftMonitor``;
- ``selection``: which tangle model and selection rule a part gets;
- ``diagram``: the pick diagram (station, perception, planner, monitor);
- ``demo``: ``tangle-drake demo``'s run.
"""
