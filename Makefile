# The one entry point of the project. Compilers and flags are the usual variables, so on a cluster:
#   module load gcc openmpi cuda; make CXX=g++ MPICXX=mpicxx NVCC=nvcc CUDA_ARCH=80 OPT="-O3 -march=native"
# What cannot be built here (no MPI compiler, no nvcc) is left out with one line saying why.

CXX       ?= g++
MPICXX    ?= mpicxx
NVCC      ?= nvcc
CUDA_ARCH ?= 90
# A sanitized build (SANITIZE below) compiles at -O1: ASan's advice, and about 40% less compile time than -O3.
OPT       ?= $(if $(SANITIZE),-O1,-O3 -march=native)
PYTHON    ?= python3
VENV      ?= .venv

# SANITIZE=address,undefined builds into its own folders (build-address-undefined/, bin-address-undefined/), so a
# sanitized build never mixes with the normal one; nvcc's objects cannot be sanitized, so CUDA is left out there.
SANITIZE ?=
comma := ,
SAN_SUFFIX := $(if $(SANITIZE),-$(subst $(comma),-,$(SANITIZE)))
BUILD ?= build$(SAN_SUFFIX)
BIN   ?= bin$(SAN_SUFFIX)
# UBSan stops at its first report instead of printing and going on, so a finding fails the test. GCC's
# "undefined" leaves out float-cast-overflow (a NaN or huge double converted to an integer, as a pixel or an
# index would be), so it is added.
SAN_FLAGS := $(if $(SANITIZE),-g -fno-omit-frame-pointer -fsanitize=$(SANITIZE) -fno-sanitize-recover=all \
               $(if $(filter undefined,$(subst $(comma), ,$(SANITIZE))),-fsanitize=float-cast-overflow))

HAVE_MPI  := $(if $(shell command -v $(MPICXX) 2>/dev/null),1,)
NVCC_PATH := $(if $(SANITIZE),,$(shell command -v $(NVCC) 2>/dev/null))
HAVE_CUDA := $(if $(NVCC_PATH),1,)
CUDA_HOME ?= $(if $(NVCC_PATH),$(abspath $(dir $(NVCC_PATH))/..),)

DEFS := $(if $(HAVE_MPI),-DHAVE_MPI -DOMPI_SKIP_MPICXX -DMPICH_SKIP_MPICXX) $(if $(HAVE_CUDA),-DHAVE_CUDA)
CPPFLAGS += -I. -I$(BUILD)/gen $(DEFS)
CXXFLAGS += -std=c++17 $(OPT) $(SAN_FLAGS) -fopenmp -Wall -Wextra -MMD -MP
NVCCFLAGS ?= -O3 -std=c++17 -arch=sm_$(CUDA_ARCH) -Xcompiler -fopenmp
LDLIBS   += -lpugixml -lpng $(if $(HAVE_CUDA),-L$(CUDA_HOME)/lib64 -Wl$(comma)-rpath$(comma)$(CUDA_HOME)/lib64 -lcublas -lcusparse -lcudart)
LINK     := $(if $(HAVE_MPI),$(MPICXX),$(CXX))
# Files that include mpi.h are compiled by the MPI wrapper, the rest by $(CXX). Without MPI, common/comm.cpp is the
# one-process version of its collectives, and the files that only exist for MPI are left out.
MPI_SOURCES := poisson/backends/mpi.cpp poisson/main.cpp common/comm.cpp radiosity/solve/mpi/mpi.cpp radiosity/solve/mpi/multi_mpi.cpp \
               radiosity/formfactor/file/mpi_rows.cpp
MPI_ONLY    := radiosity/solve/mpi/mpi.cpp radiosity/solve/mpi/multi_mpi.cpp radiosity/formfactor/file/mpi_rows.cpp

# Modules: each is a set of sources; a unit-test suite tests/unit/<suite>/ links the modules it names.
MOD_common     := common/cli.cpp common/record.cpp common/memory.cpp common/comm.cpp common/files.cpp
MOD_poisson    := poisson/backends/serial.cpp poisson/backends/openmp.cpp poisson/backends.cpp poisson/config/config.cpp poisson/verify.cpp poisson/list_backends.cpp $(if $(HAVE_MPI),poisson/backends/mpi.cpp) \
                  $(if $(HAVE_CUDA),$(wildcard poisson/backends/*.cu))
MOD_scene      := $(wildcard radiosity/scene/*.cpp)
MOD_formfactor := $(wildcard radiosity/formfactor/*.cpp) radiosity/formfactor/file/format.cpp
# The form-factor file's reader (radiosity/formfactor/file/file.hpp): sparse files and MPI ranks' rows, over the
# solve's storage.
MOD_ffile      := $(filter-out $(if $(HAVE_MPI),,$(MPI_ONLY)) radiosity/formfactor/file/format.cpp,$(wildcard radiosity/formfactor/file/*.cpp))
MOD_solve      := $(filter-out $(if $(HAVE_MPI),,$(MPI_ONLY)),$(wildcard radiosity/solve/*.cpp radiosity/solve/*/*.cpp)) \
                  $(if $(HAVE_CUDA),$(wildcard radiosity/solve/gpu/*.cu))
MOD_dist       := $(filter-out $(if $(HAVE_MPI),,$(MPI_ONLY)),$(wildcard radiosity/dist/*.cpp))
MOD_render     := $(wildcard radiosity/render/*.cpp)
MOD_app        := $(wildcard radiosity/app/*.cpp)
MOD_relight    := $(wildcard radiosity/relight/*.cpp)
SUITE_poisson    := common poisson
SUITE_scene      := common scene
SUITE_formfactor := common formfactor
SUITE_solve      := common formfactor solve ffile
SUITE_common     := common
SUITE_render     := common render
SUITE_fuzz_corpus := common scene formfactor
SUITE_dist       := common dist formfactor
SUITE_relight    := common scene formfactor solve ffile dist relight
SUITE_app        := common scene formfactor solve ffile render app dist relight
SUITES := $(notdir $(patsubst %/,%,$(wildcard tests/unit/*/)))

obj = $(patsubst %,$(BUILD)/%.o,$(1))
mods = $(call obj,$(foreach m,$(1),$(MOD_$(m))))
UNIT_TESTS := $(patsubst %,$(BUILD)/tests/%_tests,$(SUITES))
PROGRAMS := $(BIN)/poisson $(if $(wildcard radiosity/main.cpp),$(BIN)/radiosity) $(BIN)/stream

PRESET ?= quick
RUNNER ?= local
# make reproduce runs the report's tables and figure, the speed-against-accuracy sweeps and extremes (issue 6, about
# four minutes of the quick preset on 2 cores) and the MPI experiments (issue 9, about 2.5 minutes). The two longer
# studies beyond the report, the Table 4.2 audit (issue 21: 154 solves of room3, about 7 minutes at quick) and
# relighting (issue 20, about a minute), run with LONG=1, the default of every preset but quick and ci, so that the
# quick preset fits in 15 minutes on 2 cores (README, "Reproducing on your machine").
REPORT_EXPERIMENTS := formfactors table41 table42 table43 table44 table45 table43-steps32 gpu-float16 table45-overlap \
                      figure42 accuracy-formfactors \
                      accuracy-tolerance accuracy-precision accuracy-threshold accuracy-hemicube accuracy-mesh extremes \
                      mpi-formfactors mpi-radiosity mpi-large
LONG_EXPERIMENTS := table42-audit-formfactors table42-audit relight
LONG ?= $(if $(filter quick ci,$(PRESET)),0,1)
EXPERIMENTS ?= $(REPORT_EXPERIMENTS) $(if $(filter 1,$(LONG)),$(LONG_EXPERIMENTS))
# Records go under results/$(MACHINE)/: this machine's label (common/machine_label.py: host, CPU, cores, GPU) unless
# MACHINE=name is given; make plots/report MACHINE=<label> show another machine's records (e.g. the reference's).
MACHINE_ARG = $(if $(MACHINE),--machine "$$MACHINE")
# What a user names on the command line (a file, a machine, a preset, experiments) reaches the recipes through the
# environment, as "$$NAME" in the shell: never as $(NAME) inside a shell string, where a quote or a backtick in it
# would be run. make puts what is given on its command line in the recipes' environment (ARCHIVE, RESULTS, MACHINE,
# BENCH...); the names with a default here are exported below, after their definitions (an `export NAME` before
# `NAME ?= value` would define it empty). Compilers and their flags (CXX OPT NVCC...) are commands by nature.
# The targets that run Python from the project's venv install it first when it is missing or stale, as make test does.
NEEDS_DEPS = @common/deps.sh --check || common/deps.sh
.PHONY: all test unit fuzz deps clean help reproduce regenerate-reference resume plots report machines audit bench scenes gpu-kit gpu-import FORCE
all: $(PROGRAMS)
	@$(if $(HAVE_MPI),,echo "make: MPI left out: no '$(MPICXX)' on PATH (set MPICXX=...); backend mpi of bin/poisson \
	  and bin/radiosity, and bin/radiosity formfactors under mpirun, are not built")
	@$(if $(HAVE_CUDA),,echo "make: CUDA left out: $(if $(SANITIZE),nvcc's objects cannot be sanitized,no '$(NVCC)' on PATH (set NVCC=...)); backends cublas1, cublas2, cuda are not built")

help:
	@echo "make            build bin/ (what this machine can build)"
	@echo "make test       C++ unit tests (GoogleTest) and integration tests (pytest); installs deps if missing"
	@echo "make deps       install Debian packages and the Python venv ($(VENV)) the project needs"
	@echo "make reproduce  run the study at PRESET=$$PRESET on the local runner, then make report (LONG=1: with the Table 4.2 audit and relighting)"
	@echo "make resume     run (or submit) only the cases not yet recorded on this machine"
	@echo "make regenerate-reference MACHINE=<results/REFERENCE>   the reference machine's records made afresh on this machine"
	@echo "make scenes     fetch RRV's scenes 3 and 4 (room3.xml, room2.xml, teapot) into SCENES_CACHE (~/.cache/hpcgi/rrv)"
	@echo "make plots      tables and plots (results/<machine>/tables, plots) from the machine's records"
	@echo "make bench      bandwidth limit, our solvers and their peers (SciPy, NumPy, PETSc+hypre) here: results/<machine>/tables/bench_PRESET.md"
	@echo "                (BENCH=\"bench-sparse bench-relight\": only those case lists)"
	@echo "make report     the reproduced report, report/<machine>/REPORT-<preset>.md"
	@echo "make machines   report/MACHINES.md: every machine with records side by side"
	@echo "make audit      re-run a sample of this machine's recorded cases and compare (AUDIT_SAMPLE=5)"
	@echo "variables: PRESET=quick|paper RUNNER=local|slurm LONG=0|1 EXPERIMENTS=... MACHINE=<label> (default: this machine's)"
	@echo "make gpu-kit    build/gpu-kit/: a relocatable folder that runs the GPU half of the study on a bare GPU node (CUDA_ARCHS)"
	@echo "make gpu-import ARCHIVE=FILE   the records of a kit's archive into results/<its machine>/"
	@echo "make fuzz       run each fuzz target for FUZZ_SECONDS (default $$FUZZ_SECONDS): clang's libFuzzer, the importer's Hypothesis"
	@echo "make clean      remove build/ and bin/"
	@echo "variables: CXX MPICXX NVCC CUDA_ARCH OPT PYTHON VENV SANITIZE (e.g. address,undefined) FUZZ_SECONDS"

# Provenance baked into the binaries; rewritten only when its content changes, so nothing rebuilds needlessly. A
# tree is dirty when a tracked file differs from HEAD or an untracked one is not ignored; the study's outputs
# (results/, report/) do not count, since the runs themselves write them (a second make reproduce would otherwise mark
# every record dirty). Outside git (no HEAD) the tree counts as dirty.
GIT_CHANGES = $(shell git rev-parse -q --verify HEAD >/dev/null 2>&1 || echo no-head; \
                git status --porcelain -- . ':(exclude)results' ':(exclude)report' 2>/dev/null | head -1)
DIRTY_NOTE = $(if $(GIT_CHANGES),echo "$@: the tree has uncommitted changes (git status): its records are marked \
  git_dirty and the tables leave them out; commit first to make results" >&2,true)
$(BUILD)/gen/build_info.inc: FORCE
	@mkdir -p $(@D)
	@{ echo '#define HPCGI_GIT_COMMIT "$(shell git rev-parse HEAD 2>/dev/null || echo unknown)"'; \
	   echo '#define HPCGI_GIT_DIRTY $(if $(GIT_CHANGES),1,0)'; \
	   echo '#define HPCGI_CXX_VERSION "$(shell $(LINK) --version 2>/dev/null | head -1 | sed 's/"/\\"/g')"'; \
	   echo '#define HPCGI_CXXFLAGS "$(CXXFLAGS) $(DEFS)"'; \
	   echo '#define HPCGI_NVCC_VERSION "$(if $(HAVE_CUDA),$(shell $(NVCC) --version | tail -1),none)"'; } > $@.tmp
	@cmp -s $@.tmp $@ && rm $@.tmp || mv $@.tmp $@
$(BUILD)/common/record.cpp.o: $(BUILD)/gen/build_info.inc $(BUILD)/gen/record_schema.inc
# The record's one definition (common/record.schema.json), built into the programs: its version and its list of
# environment keys, the same that common/record.py reads from the file.
$(BUILD)/gen/record_schema.inc: common/record.schema.json
	@mkdir -p $(@D)
	@{ printf 'R"HPCGISCHEMA('; cat $<; printf ')HPCGISCHEMA"\n'; } > $@
# bin/radiosity web's page template, built into the program as a raw string literal.
$(BUILD)/gen/web_page.inc: radiosity/web/page.html
	@mkdir -p $(@D)
	@{ printf 'R"HPCGIPAGE('; cat $<; printf ')HPCGIPAGE"\n'; } > $@
$(BUILD)/radiosity/app/web_cmd.cpp.o: $(BUILD)/gen/web_page.inc
unit: $(UNIT_TESTS)

$(BUILD)/%.cpp.o: %.cpp
	@mkdir -p $(@D)
	$(if $(and $(HAVE_MPI),$(filter $<,$(MPI_SOURCES))),$(MPICXX),$(CXX)) $(CPPFLAGS) $(CXXFLAGS) -c $< -o $@

$(BUILD)/%.cu.o: %.cu
	@mkdir -p $(@D)
	$(NVCC) -ccbin $(CXX) $(CPPFLAGS) $(NVCCFLAGS) -MMD -MP -c $< -o $@

$(BIN)/poisson: $(call obj,poisson/main.cpp) $(call mods,common poisson)
	@mkdir -p $(@D)
	$(LINK) $(CXXFLAGS) $^ -o $@ $(LDLIBS)

$(BIN)/stream: $(call obj,bench/stream.cpp) $(call mods,common) $(if $(HAVE_CUDA),$(call obj,bench/stream_gpu.cu))
	@mkdir -p $(@D)
	$(LINK) $(CXXFLAGS) $^ -o $@ $(LDLIBS)

$(BIN)/radiosity: $(call obj,radiosity/main.cpp) $(call mods,common scene formfactor solve ffile render app dist relight)
	@mkdir -p $(@D)
	$(LINK) $(CXXFLAGS) $^ -o $@ $(LDLIBS)

# One GoogleTest binary per suite: build/tests/<suite>_tests. Their objects are intermediate files of this pattern
# rule, which make would delete after each build and compile again the next time: .SECONDARY keeps them.
.SECONDARY:
.SECONDEXPANSION:
$(BUILD)/tests/%_tests: $$(call obj,$$(wildcard tests/unit/$$*/*.cpp)) $$(call mods,$$(SUITE_$$*))
	@mkdir -p $(@D)
	$(LINK) $(CXXFLAGS) $^ -o $@ -lgtest_main -lgtest -pthread $(LDLIBS)

# Fuzzing (tests/fuzz/): libFuzzer targets built by clang with ASan and UBSan into build-fuzz/, run one after the
# other for FUZZ_SECONDS each by tests/fuzz/run, which reports the executions and fails on any finding.
FUZZ_CXX     ?= clang++
FUZZ_SECONDS ?= 60
FUZZ_BUILD   ?= build-fuzz
FUZZ_TARGETS := scene scene_nested ff_file
FUZZ_SRC_scene   := tests/fuzz/fuzz_scene.cpp $(MOD_scene) common/files.cpp
FUZZ_SRC_scene_nested := tests/fuzz/fuzz_scene_nested.cpp $(MOD_scene) common/files.cpp
FUZZ_SRC_ff_file := tests/fuzz/fuzz_ff_file.cpp radiosity/formfactor/file/format.cpp radiosity/formfactor/form_factors.cpp common/files.cpp
FUZZ_HEADERS := $(wildcard common/*.hpp radiosity/*.hpp radiosity/scene/*.hpp radiosity/formfactor/*.hpp tests/fuzz/*.hpp)
$(FUZZ_BUILD)/fuzz_%: $$(FUZZ_SRC_$$*) $(FUZZ_HEADERS)
	@mkdir -p $(@D)
	$(FUZZ_CXX) -std=c++17 -g -O1 -I. -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
	  $(FUZZ_SRC_$*) -o $@ -lpugixml
# Python targets (Hypothesis, from the venv): tests/fuzz/fuzz_<target>.py; import is make gpu-import's reader.
FUZZ_PY_TARGETS := import
fuzz: $(patsubst %,$(FUZZ_BUILD)/fuzz_%,$(FUZZ_TARGETS))
	$(NEEDS_DEPS)
	tests/fuzz/run "$$FUZZ_BUILD" "$$FUZZ_SECONDS" $(FUZZ_TARGETS) $(FUZZ_PY_TARGETS)

deps:
	@common/deps.sh

# make test: install what is missing, build, run the C++ unit tests, then pytest (whose summary line is last).
test:
	@common/deps.sh --check || common/deps.sh
	@$(MAKE) --no-print-directory $(if $(SANITIZE),,all) $(UNIT_TESTS)
	@for t in $(UNIT_TESTS); do echo "== $$t"; $$t --gtest_brief=1 || exit 1; done
	$(if $(SANITIZE),@echo "make test: SANITIZE=$(SANITIZE) runs the C++ unit tests; the integration tests run in plain make test",$(VENV)/bin/python -m pytest tests)

# The study: the case lists of slurm/cases/$(PRESET), run locally (RUNNER=local: slurm/run-local, then the
# tables, plots and report) or submitted as job arrays (RUNNER=slurm: slurm/submit, make plots chained after).
# Locally it ends with the runner's summary (cases run, skipped and why, failed) and exits non-zero only if a case
# failed; a case skipped for want of a GPU or of RRV's scenes is no failure.
# Before anything else: this machine's label, and whether it may add records to that folder (another machine's, the
# reference's committed folder above all, is refused with one line: common/machine_label.py).
CHECK_LABEL = label=$$(python3 common/machine_label.py --check "$${RESULTS:-results}" 2>&1) || \
  { echo "$@: $${label\#machine_label: }" >&2; exit 2; }
reproduce:
	@$(CHECK_LABEL); echo "reproduce: machine $$label (records in results/$$label/), preset $$PRESET, runner $$RUNNER"
	@$(DIRTY_NOTE)
	$(NEEDS_DEPS)
	@$(MAKE) --no-print-directory -j$$(nproc) all
ifeq ($(RUNNER),slurm)
	set -f; slurm/submit $$EXPERIMENTS
else
	@# Each make reproduce has a summary file of its own, so two at once each print their own summary.
	@set -f; summary=$$(mktemp); trap 'rm -f "$$summary"' EXIT; \
	HPCGI_SUMMARY_OUT=$$summary slurm/run-local $$EXPERIMENTS; status=$$?; \
	$(MAKE) --no-print-directory report || status=1; \
	echo; cat "$$summary"; exit $$status
endif

# The reference machine's folder changes only here, by name (slurm/regenerate-reference: from a clean tree; where the
# folder is not yet this machine's, its old records leave the live files in a commit of their own first).
regenerate-reference:
	slurm/regenerate-reference "$$MACHINE"

# Only what is missing or failed: locally the runner skips recorded cases anyway; on Slurm the missing indices.
resume:
	@$(MAKE) --no-print-directory all
ifeq ($(RUNNER),slurm)
	set -f; RESUME=1 slurm/submit $$EXPERIMENTS
else
	set -f; slurm/run-local $$EXPERIMENTS
endif

# The bandwidth limit, our solvers per iteration and their peers on this machine, one table of ratios
# (slurm/bench: the bench-* case lists of PRESET through the local runner; docs/design-notes.md, section Performance).
bench:
	@$(CHECK_LABEL)
	@$(DIRTY_NOTE)
	$(NEEDS_DEPS)
	@$(MAKE) --no-print-directory all
	slurm/bench

plots:
	$(NEEDS_DEPS)
	$(VENV)/bin/python -m analysis tables "$$PRESET" $(MACHINE_ARG)

report: plots
	$(VENV)/bin/python -m analysis report "$$PRESET" $(MACHINE_ARG)

# report/MACHINES.md: every machine with records side by side; written only when asked (a machine's own make
# reproduce or make report never rewrites the committed file).
machines:
	$(NEEDS_DEPS)
	$(VENV)/bin/python -m analysis machines "$$PRESET"

# RRV's scenes 3 and 4 from its public repository at one commit, checked by SHA-256 (RRV_URL=, SCENES_CACHE=).
scenes:
	radiosity/scenes/rrv/fetch

# Re-runs a sample of recorded cases here and compares outcome and time with the records (slurm/audit).
AUDIT_SAMPLE ?= 5
audit:
	$(NEEDS_DEPS)
	$(VENV)/bin/python slurm/audit "$$PRESET" --sample "$$AUDIT_SAMPLE" $(MACHINE_ARG)

clean:
	rm -rf $(BUILD) $(BIN)

# The GPU kit (docs/running.md, section "On a bare GPU node"): the programs built for CUDA_ARCHS without MPI into their own
# objects (KIT_BUILD; KIT_OPT instead of -march=native, since the node's CPU is not this one), linked by
# gpukit/link.mk, then packed by gpukit/pack.py into KIT with the libraries, scenes, case lists and gpu-kit/run, and
# stand-ins for cuBLAS and cuSPARSE built by CC (lib/stubs: used on a node that lacks them, so the rest runs). It
# refuses a tree with uncommitted changes (GIT_CHANGES, the rule of the binaries' git_dirty): DIRTY_KIT=1 to try one.
KIT        ?= build/gpu-kit
CUDA_ARCHS ?= $(CUDA_ARCH)
KIT_OPT    ?= -O3 -march=x86-64-v3
# make does not rebuild objects when flags change: each configuration (archs, flags, compilers) builds into a folder
# of its own, so CUDA_ARCHS="80 90" never packs objects compiled for 90 alone.
KIT_BUILD  ?= build/gpu-kit-obj/$(shell echo '$(CUDA_ARCHS) | $(KIT_OPT) | $(CXX) | $(NVCC)' | md5sum | cut -c1-8)
KIT_GENCODE := $(foreach a,$(CUDA_ARCHS),-gencode arch=compute_$(a),code=sm_$(a)) \
               -gencode arch=compute_$(lastword $(CUDA_ARCHS)),code=compute_$(lastword $(CUDA_ARCHS))
export PRESET RUNNER EXPERIMENTS AUDIT_SAMPLE KIT CUDA_ARCHS FUZZ_SECONDS FUZZ_BUILD
gpu-kit:
	@$(if $(HAVE_CUDA),,echo "make gpu-kit: needs nvcc (CUDA 13) on PATH or NVCC=...; none found" >&2; exit 2)
	@dirty=$(if $(GIT_CHANGES),1,); if [ -n "$$dirty" ] && [ "$$DIRTY_KIT" != 1 ]; then echo "make gpu-kit: the tree \
	has uncommitted changes (git status): the kit's records would carry a dirty commit and no table would count them; \
	commit first (DIRTY_KIT=1 makes one anyway, to try it)" >&2; exit 2; elif [ -n "$$dirty" ]; then echo "make \
	gpu-kit: DIRTY_KIT=1: a kit of a tree with uncommitted changes, whose records no table will count" >&2; fi
	@scenes=$$(radiosity/scenes/rrv/dir) || { echo "make gpu-kit: the kit carries RRV's scenes, and $$scenes \
	lacks room2.xml, room3.xml or teapot.obj: run 'make scenes' or set RRV_SCENES=DIR" >&2; exit 2; }
	@$(MAKE) --no-print-directory -f Makefile -f gpukit/link.mk BUILD=$(KIT_BUILD) BIN=$(KIT_BUILD)/bin \
	  MPICXX=no-mpi-in-the-kit OPT="$(KIT_OPT)" NVCCFLAGS="-O3 -std=c++17 $(KIT_GENCODE) -Xcompiler -fopenmp" \
	  $(KIT_BUILD)/bin/poisson $(KIT_BUILD)/bin/radiosity $(KIT_BUILD)/bin/stream $(KIT_BUILD)/tests/solve_tests
	scenes=$$(radiosity/scenes/rrv/dir) && $(PYTHON) gpukit/pack.py --build $(KIT_BUILD) --kit "$$KIT" \
	  --cuda-home "$(CUDA_HOME)" --archs "$$CUDA_ARCHS" --rrv-scenes "$$scenes" --cc "$(CC)"

# Brings a kit's archive home: its records into results/<the GPU node's label>/ (append-only; refuses a truncated
# archive or a record without a GPU with one line).
gpu-import:
	@test -n "$$ARCHIVE" || { echo "make gpu-import: say which archive: make gpu-import ARCHIVE=FILE" >&2; exit 2; }
	$(NEEDS_DEPS)
	$(VENV)/bin/python gpukit/import_archive.py "$$ARCHIVE" --results "$${RESULTS:-results}"

-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)
