"""Choosing a grasp among graspability's candidates: every way of choosing registered once
(``registry``), the rules' arithmetic (``rules``), the model and rule for a pick (``choice``),
the systems that score candidates with a CNN or the entanglement map (``cnn_system``,
``emap_system``) and the one ``GraspSelector`` every pick diagram selects with (``methods``).
"""
