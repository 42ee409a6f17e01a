"""The programs of `make bench` besides ours: bin/stream's sources (stream.cpp, stream_gpu.cu), the Python peers
(peers.py: SciPy CG, NumPy Jacobi; petsc_poisson.py: PETSc CG) and ff_file.py, the form-factor file in Python."""
