# Two commands on a fresh machine with Python 3.11+ and make:
#   make demo   creates .venv, installs crankfmu with its dependencies, builds the FMUs, runs the
#               five papers' studies, the pumping well and the engines, the harness's --demo subset on every
#               FMU (each FMU's own checks), and ends with a summary and a results page (build/demo/index.html)
#   make test   the same set-up plus the test tools (MinGW, wine, the ecos master's libtbb), then
#               the test suite and the harness's --quick subset
#   make validate  the full harness on every FMU (build/validation/report.md; about 2.6 minutes of
#               harness when the FMUs are up to date, measured on 2 cores)
#   make soak   short FMU host processes, 300 per FMU (the Python FMUs and the FMI 3.0 ones), counting
#               abnormal exits, then 10 minutes of the FMI fuzzer
#   make hosts  every third-party master on FourBar.fmu and FourBarDrive.ssp (about 2 min)
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
DEV_STAMP := $(VENV)/.dev-stamp
OUT    ?= build/demo

.PHONY: demo test venv fmu fmu-python fmu-native-a fmu-native-b demo-papers demo-well validate bench soak hosts clean

# fmpy starts its remoting server as `wine64`, which Debian installs as /usr/lib/wine/wine64
export PATH := /usr/lib/wine:$(PATH)

# crankfmu is installed as a user installs it: from its wheel (pip wheel --no-deps .), which carries
# the C kernel and the native FMUs' runtimes compiled when the wheel is built: gcc builds them (the
# runtimes also for Windows and aarch64 Linux where MinGW-w64 and the aarch64 cross compiler are
# installed); installing the wheel and building FMUs compile nothing. A change of the C sources
# builds the wheel again. What make demo uses: crankfmu and its dependencies, gcc; nothing else.
WHEEL_DIR := build/wheel
$(STAMP): pyproject.toml setup.py $(wildcard src/crankfmu/native/*/*.c src/crankfmu/native/*/*.h)
	@$(PYTHON) -c 'import sys; assert sys.version_info >= (3, 11), "crankfmu needs Python 3.11+, found " + sys.version'
	@# the wheel's build compiles the C kernel and the runtimes with gcc
	@command -v gcc >/dev/null || { apt-get update -qq && apt-get install -y -qq gcc; } \
	  || { echo "make: no gcc and apt-get could not install it (as root): building crankfmu's wheel needs it"; exit 1; }
	@echo "building crankfmu's wheel and installing it with its dependencies into $(VENV) ..."
	@$(PYTHON) -m venv $(VENV)
	@$(BIN)/python -m pip install --quiet --upgrade pip
	@rm -rf $(WHEEL_DIR)
	@# crankfmu's dependencies (pyproject's) go into the venv while the wheel is built beside: its
	@# build is mostly the packaged scenarios' reference runs, and pip's unpacking mostly I/O (the two
	@# one after the other were 117 s of make demo's 357 s on a fresh clone)
	@$(BIN)/python -c 'import tomllib; print("\n".join(tomllib.load(open("pyproject.toml", "rb"))["project"]["dependencies"]))' \
	  > $(VENV)/requirements.txt
	@$(BIN)/python -m pip install --quiet -r $(VENV)/requirements.txt > $(VENV)/install-dependencies.log 2>&1 & deps=$$!; \
	$(BIN)/python -m pip wheel --quiet --no-deps --wheel-dir $(WHEEL_DIR) . > $(VENV)/install.log 2>&1 \
	  || { kill $$deps 2>/dev/null; cat $(VENV)/install.log; echo "make: pip wheel failed (the log above: $(VENV)/install.log)"; exit 1; }; \
	wait $$deps || { cat $(VENV)/install-dependencies.log; \
	  echo "make: pip install of crankfmu's dependencies failed (the log above: $(VENV)/install-dependencies.log)"; exit 1; }
	@$(BIN)/python -m pip install --quiet --force-reinstall --no-deps $(WHEEL_DIR)/crankfmu-*.whl >> $(VENV)/install.log 2>&1 \
	  || { cat $(VENV)/install.log; echo "make: pip install of the wheel failed (the log above: $(VENV)/install.log)"; exit 1; }
	@$(BIN)/python -m pip check >> $(VENV)/install.log 2>&1 \
	  || { tail -5 $(VENV)/install.log; echo "make: crankfmu's dependencies do not hold together (pip check)"; exit 1; }
	@echo "installed $$(cd $(WHEEL_DIR) && ls crankfmu-*.whl)"
	@touch $(STAMP)

# What make test, hosts, soak and bench add: the test tools and masters, the native FMUs' win64
# cross compiler (MinGW), wine to run those DLLs, Debian's libtbb12 for the ecos master, and
# headless Chromium for the pages' tests
# (and crankfmu again, editable: the tests run the tree's sources as they are edited)
$(DEV_STAMP): $(STAMP)
	@$(BIN)/python -m pip install --quiet -e '.[dev]' > $(VENV)/install-dev.log 2>&1 \
	  || { cat $(VENV)/install-dev.log; echo "make: pip install of the test tools failed"; exit 1; }
	@# CoFMPy, a master in pure Python: without its pinned dependencies (pyproject's dev has what it imports)
	@$(BIN)/python -m pip install --quiet --no-deps cofmupy==1.0.0 >> $(VENV)/install-dev.log 2>&1 \
	  || { cat $(VENV)/install-dev.log; echo "make: pip install of cofmupy failed"; exit 1; }
	@# the native FMUs' win64 binaries: Debian's MinGW-w64 cross compiler
	@command -v x86_64-w64-mingw32-gcc >/dev/null || { apt-get update -qq && apt-get install -y -qq gcc-mingw-w64-x86-64; } \
	  || echo "make: could not install gcc-mingw-w64-x86-64 (apt-get, as root): native FMUs get no win64 binary"
	@# Windows under wine: the native FMUs' win64 DLLs through fmpy's remoting (Debian's wine64)
	@test -x /usr/lib/wine/wine64 || command -v wine64 >/dev/null || { apt-get update -qq && apt-get install -y -qq wine64; } \
	  || echo "make: could not install wine64 (apt-get, as root): the win64 DLL checks will fail"
	@# the ecos C++ master (ecospy wheel) links Debian's libtbb12
	@ldconfig -p | grep -q 'libtbb.so.12' || { apt-get update -qq && apt-get install -y -qq libtbb12; } \
	  || echo "make: could not install libtbb12 (apt-get, as root): the ecos master's checks will fail"
	@# the FMI 3.0 FMUs' aarch64-linux binaries: Debian's cross compiler, and qemu-user to run them in the tests
	@command -v aarch64-linux-gnu-gcc >/dev/null || { apt-get update -qq && apt-get install -y -qq gcc-aarch64-linux-gnu; } \
	  || echo "make: could not install gcc-aarch64-linux-gnu (apt-get, as root): FMI 3.0 FMUs get no aarch64-linux binary"
	@command -v qemu-aarch64 >/dev/null || { apt-get update -qq && apt-get install -y -qq qemu-user; } \
	  || echo "make: could not install qemu-user (apt-get, as root): the aarch64-linux checks will fail"
	@# the native FMUs' runtimes for the cross compilers just installed (the installation compiled
	@# them for those it found): a native build then carries every platform and compiles nothing
	@$(BIN)/python src/crankfmu/native/sources.py --prebuild
	@# the coverage-guided fuzzer of the native FMU's FMI API: Debian's clang (libFuzzer, sanitizers)
	@command -v clang >/dev/null || { apt-get update -qq && apt-get install -y -qq clang; } \
	  || echo "make: could not install clang (apt-get, as root): the FMI fuzzer's test will fail"
	@# the pages (the results page, the FMUs' documentation) are checked in a real browser: headless Chromium
	@command -v chromium >/dev/null || { apt-get update -qq && apt-get install -y -qq chromium; } \
	  || echo "make: could not install chromium (apt-get, as root): the pages' browser tests will fail"
	@# the FMUs built before this (make demo's, on a machine that had no cross compilers then) lack the
	@# win64 and aarch64 binaries: make fmu builds them again (its stamp names this one only when it
	@# existed as make started)
	@rm -f $(FMU_STAMP)
	@touch $(DEV_STAMP)

venv: $(STAMP)

# the FMUs, on both cores: the Python ones, and the native ones in two halves (each native build
# runs two compilers and a reference run); the win64 binaries where MinGW is installed (make test
# installs it). Built again only when a source, a data file or the installation changed since the
# last build (build/fmus/.built), so make validate and make test do not pay for FMUs up to date.
FMU_SOURCES := $(shell find src/crankfmu -type f \( -name '*.py' -o -name '*.toml' -o -name '*.c' -o -name '*.h' \
                 -o -name '*.in' \) -not -path '*/__pycache__/*') pyproject.toml setup.py Makefile
FMU_STAMP := build/fmus/.built

fmu: $(FMU_STAMP)

# (and when make test has just installed the cross compilers: the FMUs then get their win64 and
# aarch64 binaries)
$(FMU_STAMP): $(STAMP) $(FMU_SOURCES) $(wildcard $(DEV_STAMP))
	@# three lanes of builds, each with one live line (their logs in build/fmus/logs)
	@$(BIN)/python -m crankfmu.cli.lanes --logs build/fmus/logs --make-var BIN=$(BIN) --make-var STAMP= \
	  python:fmu-python native-a:fmu-native-a native-b:fmu-native-b
	@touch $@

fmu-python: $(STAMP)
	@for s in seed000 seed001 seed002 seed003 seed004 pumpjack engine1 engine4 jansen; do $(BIN)/crankfmu fmu $$s --out build/fmus || exit 1; done
	@$(BIN)/crankfmu fmu dc_pi --drive --out build/fmus
	@$(BIN)/crankfmu fmu seed000 --causality speed --out build/fmus
	@$(BIN)/crankfmu fmu dc_pi --drive --causality speed --out build/fmus
	@$(BIN)/crankfmu fmu die_cushion --cushion --out build/fmus
	@$(BIN)/crankfmu fmu elastic_shaft --shaft --out build/fmus
	@$(BIN)/crankfmu fmu rp11l_guo --well --out build/fmus

# native FMUs (C, linux64 and win64, no Python on the host)
fmu-native-a: $(STAMP)
	@# (and issue 69's slider-crank with joint friction as a Python FMU, whose build integrates its
	@# reference: 9 s, which made the Python lane the last by 7 s; the harness checks its energy
	@# balance with W_friction)
	@$(BIN)/crankfmu fmu validation/data/slidercrank_friction_scenario.toml --out build/fmus
	@# (its native FMUs next: the reference run the Python build made is in the cache)
	@$(BIN)/crankfmu fmu validation/data/slidercrank_friction_scenario.toml --native --out build/fmus/native
	@$(BIN)/crankfmu fmu validation/data/slidercrank_friction_scenario.toml --native --fmi-version 3 --out build/fmus/native3
	@for s in seed000 seed001 seed002 engine1 jansen; do $(BIN)/crankfmu fmu $$s --native --out build/fmus/native || exit 1; done
	@$(BIN)/crankfmu fmu seed000 --native --causality speed --out build/fmus/native
	@for s in seed000 seed001 seed002 engine1 jansen; do $(BIN)/crankfmu fmu $$s --native --fmi-version 3 --out build/fmus/native3 || exit 1; done

fmu-native-b: $(STAMP)
	@for s in seed003 seed004 pumpjack engine4; do $(BIN)/crankfmu fmu $$s --native --out build/fmus/native || exit 1; done
	@for s in seed003 seed004 pumpjack engine4; do $(BIN)/crankfmu fmu $$s --native --fmi-version 3 --out build/fmus/native3 || exit 1; done
	@$(BIN)/crankfmu fmu dc_pi --drive --native --out build/fmus/native
	@$(BIN)/crankfmu fmu dc_pi --drive --causality speed --native --out build/fmus/native
	@$(BIN)/crankfmu fmu die_cushion --cushion --native --out build/fmus/native
	@$(BIN)/crankfmu fmu elastic_shaft --shaft --native --out build/fmus/native
	@$(BIN)/crankfmu fmu rp11l_guo --well --native --out build/fmus/native
	@$(BIN)/crankfmu fmu dc_pi --drive --native --fmi-version 3 --out build/fmus/native3
	@$(BIN)/crankfmu fmu dc_pi --drive --causality speed --native --fmi-version 3 --out build/fmus/native3
	@$(BIN)/crankfmu fmu die_cushion --cushion --native --fmi-version 3 --out build/fmus/native3
	@$(BIN)/crankfmu fmu elastic_shaft --shaft --native --fmi-version 3 --out build/fmus/native3
	@$(BIN)/crankfmu fmu rp11l_guo --well --native --fmi-version 3 --out build/fmus/native3

# the main job: every FMU, the papers' studies and the pumping well (two lines of work on the two
# cores), the harness's --demo subset on every FMU, and a summary of what was made
demo: fmu
	@# the two lines of work side by side, each with one live line (its log in $(OUT)/logs)
	@$(BIN)/python -m crankfmu.cli.lanes --logs $(OUT)/logs --make-var OUT=$(OUT) --make-var BIN=$(BIN) --make-var STAMP= \
	  papers:demo-papers well:demo-well
	$(BIN)/crankfmu validate --demo --out $(OUT)/validation > $(OUT)/validation.log || \
	  { tail -5 $(OUT)/validation.log; echo "make demo: the harness found failures ($(OUT)/validation/report.html)"; exit 1; }
	@$(BIN)/crankfmu page $(OUT) --validation $(OUT)/validation > /dev/null
	@echo
	@echo "make demo: done."
	@echo "  built    $$(ls build/fmus/*.fmu | wc -l) Python FMUs in build/fmus/, $$(ls build/fmus/native/*.fmu | wc -l) native FMUs in build/fmus/native/, $$(ls build/fmus/native3/*.fmu | wc -l) FMI 3.0 ones in build/fmus/native3/"
	@echo "  checked  $$(tail -2 $(OUT)/validation.log | head -1) (the harness's --demo subset: each FMU's own checks;"
	@echo "           make test adds the hard cases and coupled scenes (--quick), make validate runs all)"
	@echo "  look at  $(OUT)/index.html: every figure and animation of the papers' studies, the pumping well and the engines,"
	@echo "           the published numbers beside ours, and the validation report"

# The two lanes take about as long (measured 2026-12-04: 66 and 50 s before the sweep of seed000 and
# seed001's equilibrium, 8 s together, moved to the second): engine4's flywheel study (30 s) opens
# the one with the pump jack, the well, engine1's run, that sweep and equilibrium, and Jansen's leg;
# the papers' other studies and engine1's flywheel fill the other. A run and its animation
# (--result) stay in one lane.
demo-papers: $(STAMP)
	# engine1's flywheel study first: the longest of this lane
	$(BIN)/crankfmu flywheel engine1 --delta 0.02 --out $(OUT)/engine1
	$(BIN)/crankfmu simulate seed000 --out $(OUT)
	$(BIN)/crankfmu kinematics seed002 --at 30 --out $(OUT)/seed002
	$(BIN)/crankfmu sweep seed004 --param e=0.30:0.45:4 --param l1=0.15:0.30:4 --out $(OUT)/seed004
	$(BIN)/crankfmu flywheel seed003 --delta 0.05 --out $(OUT)/seed003
	# the papers' mechanism figures beside each study's other figures, and one animation per mechanism
	$(BIN)/crankfmu draw seed000 --out $(OUT)/mechanism_fig2.png
	$(BIN)/crankfmu draw seed001 --out $(OUT)/seed001/mechanism_fig1.png
	$(BIN)/crankfmu draw seed001 --reactions --out $(OUT)/seed001/reactions_at_60deg.png
	$(BIN)/crankfmu draw seed002 --out $(OUT)/seed002/mechanism_fig2.png
	$(BIN)/crankfmu draw seed003 --out $(OUT)/seed003/mechanism_fig1.png
	$(BIN)/crankfmu draw seed004 --velocities --out $(OUT)/seed004/mechanism_fig1.png
	for s in seed001 seed002 seed003 seed004; do $(BIN)/crankfmu animate $$s --out $(OUT)/$$s/mechanism.gif || exit 1; done
	$(BIN)/crankfmu animate seed000 --result $(OUT) --out $(OUT)/seed000_run.gif

demo-well: $(STAMP)
	# the engines, a machine cycle of two turns: the turning moment, omega1 over the cycle, the flywheel
	$(BIN)/crankfmu flywheel engine4 --delta 0.005 --out $(OUT)/engine4
	$(BIN)/crankfmu simulate engine1 --method fast --out $(OUT)/engine1
	$(BIN)/crankfmu draw engine1 --out $(OUT)/engine1/mechanism.png
	# the papers' sweep of the motor and flywheel, and the equilibrium moments (here: this lane is the shorter)
	$(BIN)/crankfmu sweep seed000 --param J_flywheel=0:20:100 --param B=10:30:100 --out $(OUT)/seed000-sweep --restart
	$(BIN)/crankfmu equilibrium seed001 --omega 15,10,7,5 --out $(OUT)/seed001
	# the beam pumping unit (data files only): gearbox torque with and without counterbalance, a run,
	# and the well: dynamometer cards, torque, animation
	$(BIN)/crankfmu equilibrium pumpjack --omega 0.838 --out $(OUT)/pumpjack
	$(BIN)/crankfmu equilibrium pumpjack --omega 0.838 --set m_cw=0 --out $(OUT)/pumpjack-no-counterbalance
	$(BIN)/crankfmu simulate pumpjack --method fast --out $(OUT)/pumpjack
	$(BIN)/crankfmu draw pumpjack --out $(OUT)/pumpjack/mechanism.png
	$(BIN)/crankfmu animate pumpjack --result $(OUT)/pumpjack --out $(OUT)/pumpjack/run.gif
	$(BIN)/crankfmu well rp11l_guo --out $(OUT)/well
	# a machine that touches: Jansen's leg walking on the ground (a max() contact), its foot's path
	$(BIN)/crankfmu simulate jansen --method fast --out $(OUT)/jansen
	$(BIN)/crankfmu draw jansen --out $(OUT)/jansen/mechanism.png
	$(BIN)/crankfmu animate jansen --result $(OUT)/jansen --out $(OUT)/jansen/run.gif

# one test file per worker: a file's module fixtures (the fuzz children, the drop-in venvs) run once;
# the 15 slowest tests listed at the end (the suite's time on two cores is watched: about 15 minutes)
test: $(DEV_STAMP) fmu
	$(BIN)/python -m pytest -q -n 2 --dist loadfile --durations=15
	$(BIN)/crankfmu validate --quick --out build/validation-quick

validate: fmu
	$(BIN)/crankfmu validate --out build/validation

bench: $(DEV_STAMP) fmu
	$(BIN)/python benchmarks/speed.py --out build/bench
	$(BIN)/python benchmarks/c_model.py --json build/bench/c_model.json > build/bench/c_model.md

# the drop-in check: fmpy, the ecos C++ command, ecospy and libcosim on FourBar.fmu and
# FourBarDrive.ssp (co-simulation error at 10, 1 and 0.1 ms against the coupled model in process)
hosts: $(DEV_STAMP) fmu
	$(BIN)/crankfmu fmu validation/data/togglepress_scenario.toml --out build/fmus
	$(BIN)/crankfmu hosts --out build/hosts

# 1,800 short host processes (300 per FMU: fmpy and the C driver, logging on and off, a refused
# parameter, a host exiting with the instance alive); exits 1 on any abnormal exit
soak: $(DEV_STAMP) fmu
	$(BIN)/python tests/soak.py --per-fmu 300 --fmus build/fmus --fmus build/fmus/native3
	$(BIN)/python tests/test_fmi_fuzzer.py 600

clean:
	rm -rf build .pytest_cache
