"""The tangle CNN (paper section III-C): does this grasp lift one and only one part?

A small AlexNet-like classifier of the rotated metric depth crop
(``tangle_drake.perception.crops``; all the candidates of one image:
``crops.candidate_crops``) that outputs P(not tangled) per grasp
candidate, and its training (``tangle-drake train``); the rules that combine it with
graspability, and the Drake system that scores candidates with it, are
:mod:`tangle_drake.selection`'s. Modules import torch only where they need it, so this
package's import is cheap:

- ``network``: the layers; ``normalise``: depth crop -> network input; ``target_mask``: the
  input's second channel, the target part's pixels;
- ``augment``, ``split``, ``metrics``, ``training_data``, ``train``: training;
- ``checkpoint``: the file format; ``model``: ``load_tangle_model`` and ``TangleModel``;
- ``objectives``: what a model predicts, and which rules read it (the rules and the Drake
  systems that select with a model are :mod:`tangle_drake.selection`'s);
- ``onnx_export``: ONNX for other runtimes;
- ``synthetic``: a separable stand-in dataset for tests and the benchmark.
"""
