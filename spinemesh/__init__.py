"""spinemesh: automatic triangle meshes for Spine projects.

The pipeline, in the order the modules appear:

- ``atlas``, ``images``: texture atlases and the original-size image of every region;
- ``skeleton`` (JSON) and ``skeleton_binary`` (``.skel``): skeleton documents;
- ``project``: finds skeletons, atlases and image folders in a project folder;
- ``mesher``: one image to one triangle mesh;
- ``upgrade``: whole projects, region attachments become mesh attachments;
- ``dataset``, ``segment``, ``train``, ``diff``: beside the pipeline.
"""

__version__ = "0.1.0"
