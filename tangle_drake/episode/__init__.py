"""Running picks: the pick diagram's simulator restarted from settled piles (``run``); one
episode shape for every simulated run of a scenario, a settler and a pick diagram run pile
after pile (``episode``: the demo, the benchmark's single picks and clearings, the
physical-pick data, the tools); and the pick demo (``demo``), in simulation or against the
hardware interface.
"""
