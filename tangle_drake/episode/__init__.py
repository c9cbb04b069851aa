"""Running picks: the pick diagram's simulator restarted from settled piles (``run``), one
physically simulated pick as the benchmark and the physical-pick data make it
(``single_pick``), the benchmark's methods switched per run (``methods``), and the pick demo
(``demo``), in simulation or against the hardware interface.
"""
