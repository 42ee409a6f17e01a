# Read after the Makefile by `make gpu-kit` (and only there): the kit's binaries link CUDA's runtime statically
# (the node's driver is all they need of CUDA besides cuBLAS and cuSPARSE) and find the kit's own lib/ through $ORIGIN, so the
# folder runs from wherever it is copied. cuBLAS and cuSPARSE stay dynamic: libcublasLt.so.13 alone is 540 MB, and the node's
# toolkit (or the nvidia-cublas Python package) has it; gpu-kit/run finds it and says which it used. The run path
# is DT_RPATH (--disable-new-dtags), which, unlike DT_RUNPATH, also serves the carried libraries' own needs
# (libpng16 needs libz, which the kit carries too).
LDLIBS := -lpugixml -lpng -L$(CUDA_HOME)/lib64 -lcublas -lcusparse -lcudart_static -ldl -lrt -lpthread -Wl,--disable-new-dtags,-rpath,'$$ORIGIN/../lib'
