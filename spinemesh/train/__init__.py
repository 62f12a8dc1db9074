"""Training of the segmentation network (paper section 3.1). Needs the ``train`` extra.

The package is imported only by training and export: meshing and ``spinemesh segment`` run
the shipped ONNX model with ONNX Runtime and never import torch.

Layout, as in segmentation_models_pytorch: :mod:`.encoders` (EfficientNet-B0 or -Lite0),
:mod:`.decoder` (U-Net), :mod:`.heads` (mask head), :mod:`.model` (the three together),
:mod:`.data` (samples and compositing augmentation), :mod:`.loop` (training) and
:mod:`.export` (ONNX and static int8).
"""
