"""The GPU kit (make gpu-kit): its packer, its driver (gpu-kit/run on the GPU node) and the import of its archive.
Standard library only: the driver runs on a bare GPU node with python3 and nothing else of this project."""
