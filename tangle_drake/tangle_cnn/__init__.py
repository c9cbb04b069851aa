"""The tangle CNN (paper section III-C): does this grasp lift one and only one part?

A small AlexNet-like classifier of the rotated metric depth crop (``tangle_drake.crops``; all
the candidates of one image: ``crops.candidate_crops``) that outputs P(not tangled) per grasp
candidate, its training (``tangle-drake train``), the rules that combine it with graspability
to pick one candidate, and a Drake system that does both.

Modules import torch only where they need it, so ``selection`` stays numpy-only and this
package's import is cheap:

- ``network``: the layers; ``normalise``: depth crop -> network input; ``target_mask``: the
  input's second channel, the target part's pixels;
- ``augment``, ``split``, ``metrics``, ``training_data``, ``train``: training;
- ``checkpoint``: the file format; ``model``: ``load_tangle_model`` and ``TangleModel``;
- ``selection``: graspability / cnn / harmonic / random rules;
- ``system``: ``TangleCnnSystem`` (pydrake); ``onnx_export``: ONNX for other runtimes;
- ``synthetic``: a separable stand-in dataset for tests and the benchmark.
"""
