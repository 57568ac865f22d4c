# rmdd — one non-recursive Makefile (STYLE.md "Build").
#
#   make                 build the library, tools and test binaries
#   make test            run every cmocka suite (tests/run-tests.sh) with the venv's Python
#                        (tests/busy-check: make test N times beside a CPU hog)
#   make install         PREFIX=/usr/local DESTDIR=  (programs, units, man pages,
#                        LCM types: .lcm, headers, pkg-config rmd-lcm, jar, Python)
#   make deb             the Debian package in $(BUILD)/deb (debian/README.source)
#   make man             the man pages into $(BUILD)/man (help2man)
#   make format-check    clang-format, kernel layout
#   make check-layers    includes point down the layers (tests/check-layers)
#   make lcm-python      the Python package `rmd` (types + client) into $(BUILD)/python
#   make python-venv     build/venv: a venv with `pip install './python[plot,mcap,foxglove,view,test]'`
#                        (lcm, matplotlib, mcap, jsonschema from PyPI)
#   make lcm-java        Java LCM types as $(BUILD)/rmd_types.jar, for lcm-spy
#   make fuzz            build the libFuzzer harnesses (tests/fuzz/) into build/fuzz
#                        with clang and run each FUZZ_SECONDS (10) on its corpus
#   SANITIZE=1           ASan + UBSan + float-cast-overflow (objects go to build/san)
#   WERROR=1             warnings are errors (CI sets it)
#   V=1                  echo every command

# `make` alone builds everything (the deps rule below comes first in the file).
.DEFAULT_GOAL := all

PREFIX ?= /usr/local
BINDIR ?= $(PREFIX)/bin
SYSCONFDIR ?= /etc
DESTDIR ?=
# The version: VERSION's release number plus the commits since the commit
# that set it (tools/version; debian/README.source has the table).  git
# runs in the Makefile's own checkout (a tree of symlinks to it, as the docs
# test makes, describes the same commit); make deb passes its version.
RMD_TOP := $(dir $(realpath $(firstword $(MAKEFILE_LIST))))
ifndef RMD_VERSION
RMD_VERSION := $(shell '$(RMD_TOP)tools/version')
endif

CC ?= cc
CLANG_FORMAT ?= clang-format
CFLAGS ?= -O2 -g

ifeq ($(SANITIZE),1)
BUILD ?= build/san
# gcc's `undefined` leaves out float-cast-overflow (a double out of an integer's range)
SAN_FLAGS := -fsanitize=address,undefined,float-cast-overflow -fno-omit-frame-pointer \
	     -fno-sanitize-recover=all
else
BUILD ?= build
SAN_FLAGS :=
endif

# -Wmissing-format-attribute: gcc names a function that hands its va_list
# on without format(printf, n, 0); clang (make fuzz) refuses its vsnprintf
# under -Wformat=2 instead, and only ran after the suites in CI.
WARN := -Wall -Wextra -Wshadow -Wstrict-prototypes -Wmissing-prototypes -Wformat=2 \
	-Wswitch-enum -Wvla -Wmissing-format-attribute
# CI (CI=true) builds with -Werror.
ifeq ($(CI),true)
WERROR ?= 1
endif
ifeq ($(WERROR),1)
WARN += -Werror
endif
HARDEN := -D_FORTIFY_SOURCE=2 -fstack-protector-strong -fPIE

PKGS := libmodbus yaml-0.1 lcm libsystemd
PKG_CFLAGS := $(shell pkg-config --cflags $(PKGS) 2>/dev/null)
PKG_LIBS := $(shell pkg-config --libs $(PKGS) 2>/dev/null)

override CFLAGS += -std=gnu11 $(WARN) $(HARDEN) $(SAN_FLAGS) -Iinclude -Isrc -I$(BUILD)/gen $(PKG_CFLAGS) -MMD -MP
override LDFLAGS += -pie -Wl,-z,relro,-z,now $(SAN_FLAGS)

ifeq ($(V),1)
Q :=
else
Q := @
endif

# The library's layers are folders (docs/design.md): util, proto, sim and
# config (the model), bus, rt, svc.  `make check-layers` keeps includes
# pointing down.  src/tools/<program>/ are the programs, src/tools/common/
# what they share.
LAYERS := util proto sim config bus rt svc
LIB_SRCS := $(foreach l,$(LAYERS),$(wildcard src/$(l)/*.c))
LIB_OBJS := $(LIB_SRCS:%.c=$(BUILD)/%.o)
LIB := $(BUILD)/librmd.a

# Each program is the folder src/tools/<name>/ plus src/tools/common/.
TOOL_COMMON_SRCS := $(wildcard src/tools/common/*.c)
RMDCTL_SRCS := $(wildcard src/tools/rmdctl/*.c) $(TOOL_COMMON_SRCS)
RMDCTL := $(BUILD)/rmdctl
RMDSIM_SRCS := $(wildcard src/tools/rmd-sim/*.c) $(TOOL_COMMON_SRCS)
RMDSIM := $(BUILD)/rmd-sim
RMDD_SRCS := $(wildcard src/tools/rmdd/*.c) $(TOOL_COMMON_SRCS)
RMDD := $(BUILD)/rmdd
PROGS := $(if $(RMDCTL_SRCS),$(RMDCTL)) $(if $(RMDSIM_SRCS),$(RMDSIM)) $(if $(RMDD_SRCS),$(RMDD))

# Suites: tests/unit/ (one module, in process) and tests/system/ (real
# processes, sockets, pseudo-terminals); tests/harness/ is linked into each.
TEST_SRCS := $(wildcard tests/unit/test_*.c tests/system/test_*.c)
TESTS := $(TEST_SRCS:tests/%.c=$(BUILD)/tests/%)
HARNESS_SRCS := $(wildcard tests/harness/*.c)
HARNESS_OBJS := $(HARNESS_SRCS:%.c=$(BUILD)/%.o)
TEST_LIBS := -lcmocka

LIBS := $(PKG_LIBS) -lm

# LCM types (lcm_types/<type>.lcm, package rmd, one type per file): lcm-gen
# writes their C into $(BUILD)/gen, compiled into the library; the Python
# package (python/: the types and rmd.Client) and the jar for lcm-spy are
# built on request.
LCM_GEN ?= lcm-gen
JAVAC ?= javac
JAR ?= jar
LCM_JAR ?= /usr/share/java/lcm.jar
LCM_TYPES := $(wildcard lcm_types/*.lcm)
GEN_SRCS := $(LCM_TYPES:lcm_types/%.lcm=$(BUILD)/gen/rmd_%.c)
GEN_HDRS := $(LCM_TYPES:lcm_types/%.lcm=$(BUILD)/gen/rmd/rmd_%.h)
GEN_OBJS := $(GEN_SRCS:%.c=%.o)
GEN_STAMP := $(BUILD)/gen/.stamp
# lcm-gen's C leaves a few parameters unused; the rest of the flags hold.
# Its array coders (LCM 1.3.1's lcm_coretypes.h) memcpy() 0 bytes to or from
# a NULL array when a message's count is 0 (a health_t of another daemon, a
# fuzzer's input): harmless, but UBSan's nonnull check would abort the
# sanitized and fuzz builds on LCM's code, not ours.
GEN_CFLAGS := -Wno-unused-parameter -fno-sanitize=nonnull-attribute
LCM_PYTHON := $(BUILD)/python/rmd/__init__.py
PYTHON_SRCS := python/pyproject.toml python/setup.py python/gen_types.py $(wildcard python/rmd/*.py)
# A venv with the package installed as users install it (README): the
# Python system suites run it.  One for every BUILD (SANITIZE=1 too).
VENV ?= build/venv
VENV_STAMP := $(VENV)/.installed
LCM_JAVA := $(BUILD)/rmd_types.jar

.PHONY: all test install uninstall format format-check check-layers clean deps
.SECONDARY:

# Debian/Ubuntu packages needed to build, test and run (`sudo make deps`).
# libegl1 libegl-mesa0 libgl1-mesa-dri: rmd-view's PNGs without a display
# (MuJoCo's EGL on Mesa's software renderer; docs/physics.md).
DEB_PACKAGES := build-essential pkg-config clang-format libcmocka-dev libmodbus-dev \
	libyaml-dev can-utils python3 python3-venv liblcm-dev liblcm-bin libglib2.0-dev \
	liblcm-java default-jdk-headless libsystemd-dev rt-tests iproute2 valgrind python3-matplotlib python3-jsonschema python3-yaml \
	clang libclang-rt-dev stress-ng socat xvfb xauth default-jre libjchart2d-java \
	debhelper dh-python help2man man-db debootstrap libncurses-dev tmux \
	libmujoco-dev cyclonedds-dev cyclonedds-tools nftables libegl1 libegl-mesa0 libgl1-mesa-dri

deps:
	apt-get update -qq
	DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $(DEB_PACKAGES)
	tests/vm/vm-setup
all: $(LIB) $(PROGS) $(TESTS)

$(BUILD)/%.o: %.c
	@mkdir -p $(dir $@)
	@$(if $(Q),echo "  CC      $<")
	$(Q)$(CC) $(CPPFLAGS) $(CFLAGS) -c -o $@ $<

$(LIB): $(LIB_OBJS)
	@$(if $(Q),echo "  AR      $@")
	$(Q)rm -f $@ && $(AR) rcs $@ $^

.PHONY: lcm-python lcm-java python-venv

$(GEN_STAMP): $(LCM_TYPES)
	@mkdir -p $(BUILD)/gen/rmd
	@$(if $(Q),echo "  LCMGEN  $(BUILD)/gen")
	$(Q)$(LCM_GEN) -c --c-cpath $(BUILD)/gen --c-hpath $(BUILD)/gen/rmd --cinclude rmd $(LCM_TYPES)
	$(Q)touch $@

$(GEN_SRCS) $(GEN_HDRS): $(GEN_STAMP) ;

$(BUILD)/gen/%.o: $(BUILD)/gen/%.c
	@$(if $(Q),echo "  CC      $<")
	$(Q)$(CC) $(CPPFLAGS) $(CFLAGS) $(GEN_CFLAGS) -c -o $@ $<

$(LIB): $(GEN_OBJS)

# The generated headers exist before anything that may include them is compiled.
$(LIB_OBJS) $(TESTS:%=%.o) $(HARNESS_OBJS) $(RMDCTL_SRCS:%.c=$(BUILD)/%.o) $(RMDSIM_SRCS:%.c=$(BUILD)/%.o) \
	$(RMDD_SRCS:%.c=$(BUILD)/%.o): | $(GEN_HDRS)

lcm-python: $(LCM_PYTHON)

# The whole package, for PYTHONPATH=$(BUILD)/python in a checkout: the
# generated types and python/rmd/*.py (python/gen_types.py, as pip does).
# rmd.__version__ is RMD_VERSION: made again when it changes (VERSION_HDR, below).
$(LCM_PYTHON): $(LCM_TYPES) $(PYTHON_SRCS)
	@$(if $(Q),echo "  LCMGEN  $(BUILD)/python/rmd")
	$(Q)rm -rf $(BUILD)/python/rmd && mkdir -p $(BUILD)/python
	$(Q)LCM_GEN=$(LCM_GEN) RMD_VERSION='$(RMD_VERSION)' python3 python/gen_types.py $(BUILD)/python --with-sources

python-venv: $(VENV_STAMP)

# `make test` needs it: when it cannot be made, say why and what to install.
$(VENV_STAMP): $(LCM_TYPES) $(PYTHON_SRCS)
	@$(if $(Q),echo "  VENV    $(VENV) (pip install './python[plot,mcap,foxglove,view,test]')")
	$(Q)test -x $(VENV)/bin/pip || { rm -rf $(VENV) && python3 -m venv $(VENV); } || { \
		rm -rf $(VENV); echo "make python-venv: python3 -m venv $(VENV) failed:" \
		"install python3 and python3-venv (sudo make deps)" >&2; exit 1; }
	$(Q)LCM_GEN=$(LCM_GEN) $(VENV)/bin/python3 -m pip install --quiet --disable-pip-version-check \
		'./python[plot,mcap,foxglove,view,test]' || { echo "make python-venv: pip install" \
		"'./python[plot,mcap,foxglove,view,test]' into $(VENV) failed: it fetches lcm, matplotlib, mcap," \
		"foxglove-sdk, mujoco, jsonschema and websockets from PyPI, so it needs the network" \
		"(or a mirror: PIP_INDEX_URL, PIP_FIND_LINKS)" >&2; exit 1; }
	$(Q)LCM_GEN=$(LCM_GEN) $(VENV)/bin/python3 -m pip install --quiet --disable-pip-version-check \
		--force-reinstall --no-deps ./python
	$(Q)touch $@

# For `make test`: a directory holding one program, a python3 that is the
# venv's, to put first on PATH.  test_lcm_system and the docs scenarios run
# `python3` from PATH (Debian's cannot import lcm); the venv's bin/ itself
# also has PyPI lcm's lcm-gen and lcm-logger, which must not shadow Debian's.
VENV_PATH := $(VENV)-path
$(VENV_PATH)/python3: $(VENV_STAMP)
	@mkdir -p $(dir $@)
	$(Q)printf '#!/bin/sh\nexec "%s/bin/python3" "$$@"\n' "$(abspath $(VENV))" >$@
	$(Q)chmod +x $@

lcm-java: $(LCM_JAVA)

# CLASSPATH=$(LCM_JAVA) lcm-spy decodes rmdd's channels.
$(LCM_JAVA): $(LCM_TYPES)
	@$(if $(Q),echo "  JAR     $@")
	$(Q)rm -rf $(BUILD)/java && mkdir -p $(BUILD)/java/classes
	$(Q)$(LCM_GEN) -j --jpath $(BUILD)/java/src $(LCM_TYPES)
	$(Q)$(JAVAC) -nowarn -cp $(LCM_JAR) -d $(BUILD)/java/classes $(BUILD)/java/src/rmd/*.java
	$(Q)$(JAR) cf $@ -C $(BUILD)/java/classes .

# RMD_VERSION reaches the programs through one header, rewritten only when
# the string changes: a new commit relinks nothing, and the library never
# sees it.
VERSION_HDR := $(BUILD)/gen/rmd_version.h
.PHONY: FORCE
$(VERSION_HDR): FORCE
	@mkdir -p $(dir $@)
	$(Q)printf '#define RMD_VERSION "%s"\n' '$(RMD_VERSION)' >$@.tmp
	$(Q)if cmp -s $@.tmp $@; then rm -f $@.tmp; else mv -f $@.tmp $@; fi
$(RMDCTL_SRCS:%.c=$(BUILD)/%.o) $(RMDSIM_SRCS:%.c=$(BUILD)/%.o) $(RMDD_SRCS:%.c=$(BUILD)/%.o): \
	| $(VERSION_HDR)
$(LCM_PYTHON): $(VERSION_HDR)

# Bash completion, from each program's own option tables (PROG --completion bash).
COMPLETIONS := $(patsubst $(BUILD)/%,$(BUILD)/completion/%,$(PROGS))
BASHCOMPDIR ?= $(PREFIX)/share/bash-completion/completions
all: $(COMPLETIONS)
$(BUILD)/completion/%: $(BUILD)/%
	@mkdir -p $(dir $@)
	@$(if $(Q),echo "  GEN     $@")
	$(Q)$< --completion bash >$@.tmp && mv -f $@.tmp $@

# rmdctl top's screen (src/tools/rmdctl/top_screen.c) is drawn with
# ncurses: only that file sees its flags, only rmdctl links it.
CURSES_CFLAGS := $(shell pkg-config --cflags ncurses 2>/dev/null)
CURSES_LIBS := $(or $(shell pkg-config --libs ncurses 2>/dev/null),-lncurses)
$(BUILD)/src/tools/rmdctl/top_screen.o: override CFLAGS += $(CURSES_CFLAGS)

$(RMDCTL): $(RMDCTL_SRCS:%.c=$(BUILD)/%.o) $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(LIBS) $(CURSES_LIBS)

$(RMDSIM): $(RMDSIM_SRCS:%.c=$(BUILD)/%.o) $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

$(RMDD): $(RMDD_SRCS:%.c=$(BUILD)/%.o) $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

# The physics module (docs/physics.md): src/physics/ against MuJoCo
# (libmujoco-dev), a shared object the simulator dlopen()s only when a
# configuration asks for physics; nothing else links libmujoco.  Without
# MuJoCo's headers it is not built, and such a configuration says so.
# It goes to $(RMD_PHYSICS_DIR), where the simulator looks for it
# (RMD_PHYSICS_MODULE_PATH; in a build tree it finds build/lib/ first).
RMD_PHYSICS_DIR ?= $(LIBDIR)/rmdd
MUJOCO_H := $(wildcard /usr/include/mujoco/mujoco.h)
PHYSICS_SO := $(BUILD)/lib/rmd-physics.so
PHYSICS_OBJS := $(patsubst %.c,$(BUILD)/pic/%.o,$(wildcard src/physics/*.c))
$(BUILD)/src/sim/sim_body.o: CPPFLAGS += -DRMD_PHYSICS_MODULE_PATH='"$(RMD_PHYSICS_DIR)/rmd-physics.so"'
ifneq ($(MUJOCO_H),)
all: $(PHYSICS_SO)
endif
$(BUILD)/pic/%.o: %.c
	@mkdir -p $(dir $@)
	@$(if $(Q),echo "  CC      $< (PIC)")
	$(Q)$(CC) $(CPPFLAGS) $(CFLAGS) -fPIC -c -o $@ $<

$(PHYSICS_SO): $(PHYSICS_OBJS)
	@mkdir -p $(dir $@)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) -shared $(SAN_FLAGS) -Wl,-z,relro,-z,now -o $@ $^ -lmujoco -lm

# rmdd with its test hooks (RMDD_TEST_STALL_AFTER_MS), for the suites that
# need them; the installed rmdd has none.  Only main.c differs.
RMDD_TEST := $(BUILD)/rmdd-test
RMDD_TEST_MAIN := $(BUILD)/test-hooks/src/tools/rmdd/main.o
all: $(RMDD_TEST)
$(RMDD_TEST_MAIN): src/tools/rmdd/main.c | $(GEN_HDRS) $(VERSION_HDR)
	@mkdir -p $(dir $@)
	@$(if $(Q),echo "  CC      $< (test hooks)")
	$(Q)$(CC) $(CPPFLAGS) $(CFLAGS) -DRMDD_TEST_HOOKS -c -o $@ $<

$(RMDD_TEST): $(RMDD_TEST_MAIN) $(filter-out %/rmdd/main.o,$(RMDD_SRCS:%.c=$(BUILD)/%.o)) $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

# The C example controller (examples/README.md): liblcm and the generated
# rmd types only, which it takes from the library.
SINE_CONTROLLER := $(BUILD)/sine_controller
all: $(SINE_CONTROLLER)
$(BUILD)/examples/sine_controller.o: | $(GEN_HDRS)
$(SINE_CONTROLLER): $(BUILD)/examples/sine_controller.o $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

# The leg's controller (examples/physics/README.md): the same, beside the
# leg's kinematics (examples/physics/leg.h).
LEG_STAND := $(BUILD)/leg_stand
all: $(LEG_STAND)
$(BUILD)/examples/physics/leg_stand.o: | $(GEN_HDRS)
$(LEG_STAND): $(BUILD)/examples/physics/leg_stand.o $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

# rmd-ros2 (docs/ros2.md): rmdd on ROS 2's wire, a program of its own on
# Cyclone DDS (cyclonedds-dev, and idlc from cyclonedds-tools, in
# DEB_PACKAGES).  idlc writes the C of the ROS 2 messages
# (src/tools/rmd-ros2/ros2_msgs.idl) into $(BUILD)/gen-ros2.  Without Cyclone
# DDS everything else builds and `make` says the bridge is not built.
IDLC ?= idlc
DDS_CFLAGS := $(shell pkg-config --cflags CycloneDDS 2>/dev/null)
DDS_LIBS := $(shell pkg-config --libs CycloneDDS 2>/dev/null)
HAVE_DDS := $(if $(DDS_LIBS),$(if $(shell command -v $(IDLC) 2>/dev/null),1))
ROS2_IDL := src/tools/rmd-ros2/ros2_msgs.idl
ROS2_GEN := $(BUILD)/gen-ros2
ROS2_MSGS_OBJ := $(ROS2_GEN)/ros2_msgs.o
ROS2_OBJS := $(patsubst %.c,$(BUILD)/%.o,$(wildcard src/tools/rmd-ros2/*.c) $(TOOL_COMMON_SRCS))
RMD_ROS2 := $(BUILD)/rmd-ros2
# tests/ros2/: the suites that need Cyclone DDS (not in TESTS' wildcard).
ROS2_TESTS := $(patsubst tests/%.c,$(BUILD)/tests/%,$(wildcard tests/ros2/test_*.c))
.PHONY: ros2-not-built
ifeq ($(HAVE_DDS),1)
all: $(RMD_ROS2) $(ROS2_TESTS)
$(ROS2_GEN)/ros2_msgs.c $(ROS2_GEN)/ros2_msgs.h &: $(ROS2_IDL)
	@mkdir -p $(ROS2_GEN)
	@$(if $(Q),echo "  IDLC    $<")
	$(Q)cd $(ROS2_GEN) && $(IDLC) -Wno-implicit-extensibility $(abspath $<)
# idlc's C, like lcm-gen's, is compiled as it comes.
$(ROS2_MSGS_OBJ): $(ROS2_GEN)/ros2_msgs.c $(ROS2_GEN)/ros2_msgs.h
	@$(if $(Q),echo "  CC      $<")
	$(Q)$(CC) $(CPPFLAGS) -O2 -g -fPIE $(DDS_CFLAGS) -c -o $@ $<
$(BUILD)/src/tools/rmd-ros2/%.o $(BUILD)/tests/ros2/%.o: override CFLAGS += $(DDS_CFLAGS) \
	-I$(ROS2_GEN) -Isrc/tools/rmd-ros2
$(ROS2_OBJS) $(ROS2_TESTS:%=%.o): | $(ROS2_GEN)/ros2_msgs.h $(GEN_HDRS)
$(RMD_ROS2): $(ROS2_OBJS) $(ROS2_MSGS_OBJ) $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(LIBS) $(DDS_LIBS)
$(BUILD)/tests/ros2/%: $(BUILD)/tests/ros2/%.o $(BUILD)/src/tools/rmd-ros2/map.o \
		$(BUILD)/src/tools/common/names.o $(ROS2_MSGS_OBJ) $(HARNESS_OBJS) $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(TEST_LIBS) $(LIBS) $(DDS_LIBS)
else
ROS2_TESTS :=
all: ros2-not-built
ros2-not-built:
	@echo "rmd-ros2: not built: no Cyclone DDS (pkg-config CycloneDDS, $(IDLC)); sudo apt install cyclonedds-dev cyclonedds-tools"
endif

# bench/insn-per-cycle.sh and bench/insn-guard.sh run this rig under
# callgrind: the loop on simulated buses with an injected clock.
INSN_RIG := $(BUILD)/bench/insn_rig
all: $(INSN_RIG)
$(BUILD)/bench/insn_rig.o: override CFLAGS += -Itests
$(BUILD)/bench/insn_rig.o: | $(GEN_HDRS)
$(INSN_RIG): $(BUILD)/bench/insn_rig.o $(BUILD)/tests/harness/clock.o $(BUILD)/tests/harness/loop_io.o $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

# bench/physics-rtf.sh's rig: motors on a model's joints, stepped as fast as they go.
PHYSICS_RTF := $(BUILD)/bench/physics_rtf
all: $(PHYSICS_RTF)
$(BUILD)/bench/physics_rtf.o: | $(GEN_HDRS)
$(PHYSICS_RTF): $(BUILD)/bench/physics_rtf.o $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

# bench/robot-delay.sh's separate machines: tests/harness/netns.c's namespaces, held up.
NETNS_RIG := $(BUILD)/bench/netns_rig
all: $(NETNS_RIG)
$(BUILD)/bench/netns_rig.o: override CFLAGS += -Itests
$(NETNS_RIG): $(BUILD)/bench/netns_rig.o $(BUILD)/tests/harness/netns.o \
		$(BUILD)/tests/harness/proc.o $(BUILD)/tests/harness/sleeper.o $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(LIBS) $(TEST_LIBS)

# bench/soak.sh's wire checker: every setpoint on the sim buses' tap against the limits.
SOAK_WIRE := $(BUILD)/bench/soak_wire
all: $(SOAK_WIRE)
$(BUILD)/bench/soak_wire.o: | $(GEN_HDRS)
$(SOAK_WIRE): $(BUILD)/bench/soak_wire.o $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

# bench/vs-blocking.sh's baseline: a sequential request/reply driver.
BLOCKING_DRIVER := $(BUILD)/bench/blocking_driver
all: $(BLOCKING_DRIVER)
$(BUILD)/bench/blocking_driver.o: | $(GEN_HDRS)
$(BLOCKING_DRIVER): $(BUILD)/bench/blocking_driver.o $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

# bench/control-delay.sh's controller (answers each state_t at once) and its matcher.
DELAY_CONTROLLER := $(BUILD)/bench/delay_controller
all: $(DELAY_CONTROLLER)
$(BUILD)/bench/delay_controller.o: | $(GEN_HDRS)
$(DELAY_CONTROLLER): $(BUILD)/bench/delay_controller.o $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

# Suites include the harness as "harness/<name>.h".
$(BUILD)/tests/%.o: override CFLAGS += -Itests

$(BUILD)/tests/%: $(BUILD)/tests/%.o $(HARNESS_OBJS) $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(TEST_LIBS) $(LIBS)

# test_sim_params holds rmd-sim's own reader (its config.c) against the table rmdd.yaml reads.
$(BUILD)/tests/unit/test_sim_params: $(BUILD)/tests/unit/test_sim_params.o \
		$(BUILD)/src/tools/rmd-sim/config.o $(HARNESS_OBJS) $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(TEST_LIBS) $(LIBS)

# test_rmdd_events holds rmdd's wording of the loop's events (src/tools/rmdd/events.c) through
# its monitor: the daemon's parts, but its main().
$(BUILD)/tests/unit/test_rmdd_events: $(BUILD)/tests/unit/test_rmdd_events.o \
		$(filter-out %/rmdd/main.o,$(RMDD_SRCS:%.c=$(BUILD)/%.o)) $(HARNESS_OBJS) $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(TEST_LIBS) $(LIBS)

# test_new_dialect: a dialect with a table of its own (tests/unit/new_dialect/),
# added as docs/design.md "How to add a dialect" says, given to every file the
# suite compiles (-include): the proto layer and rmdctl's encode and decode,
# built from their sources as they are, into a folder of their own.
NEW_DIALECT := tests/unit/new_dialect/dialect_v5.h
NEW_DIALECT_DIR := $(BUILD)/new-dialect
NEW_DIALECT_SRCS := $(wildcard src/proto/*.c) src/tools/rmdctl/encode.c \
	src/tools/rmdctl/decode.c src/tools/rmdctl/parse.c src/tools/common/cli.c \
	src/tools/common/log.c src/util/err.c tests/unit/new_dialect/codec_v5.c \
	tests/unit/test_new_dialect.c
NEW_DIALECT_OBJS := $(NEW_DIALECT_SRCS:%.c=$(NEW_DIALECT_DIR)/%.o)

$(NEW_DIALECT_DIR)/%.o: %.c $(NEW_DIALECT) | $(GEN_HDRS) $(VERSION_HDR)
	@mkdir -p $(dir $@)
	@$(if $(Q),echo "  CC      $< (V5)")
	$(Q)$(CC) $(CPPFLAGS) $(CFLAGS) -Itests -include $(NEW_DIALECT) -c -o $@ $<

$(BUILD)/tests/unit/test_new_dialect: $(NEW_DIALECT_OBJS) $(BUILD)/tests/harness/alloc_count.o \
	$(BUILD)/tests/harness/suite.o
	@mkdir -p $(dir $@)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(TEST_LIBS) -lm

# STYLE.md: suites are linked with malloc & co. wrapped, so that
# tests/harness/alloc_count.c can count them (the rt cycle allocates nothing).
$(BUILD)/tests/%: override LDFLAGS += -Wl,--wrap=malloc,--wrap=calloc,--wrap=realloc,--wrap=free

# Suites that need real SocketCAN (vcan0..vcan2): run on this host when its
# kernel has vcan, else in a QEMU guest (tests/vm/README.md), else skipped
# with one loud line.  They also run (and skip their CAN parts) on the host.
# VCAN_SYSTEM_TESTS: the whole system on vcan, every tests/system/test_vcan_* suite.
VCAN_SYSTEM_TESTS := $(filter $(BUILD)/tests/system/test_vcan_%,$(TESTS))
VCAN_TESTS := $(filter %/test_bus_socketcan %/test_rmd_sim,$(TESTS)) $(VCAN_SYSTEM_TESTS)
# The system suites check rates and delays of real processes; an emulated
# guest running sanitizer builds is ~20x slower than they assume, so under
# SANITIZE=1 they run on the host only (where they skip their CAN parts) and
# the daemon's memory safety is checked by its host suites.
ifeq ($(SANITIZE),1)
VCAN_TESTS := $(filter-out $(VCAN_SYSTEM_TESTS),$(VCAN_TESTS))
endif
# The docs test (tests/docs/check-docs): every command README.md and docs/
# show is run, as users type it, by a scenario or a named test; the
# SocketCAN scenarios run with the vcan suites.  Not in sanitizer runs:
# the scenarios use the plain build, as users do.
ifneq ($(SANITIZE),1)
DOCS_TESTS := tests/docs/check-docs tests/docs/check-schema
VCAN_TESTS += tests/docs/check-docs-can
endif

# test_systemd runs rmdd.service under systemd as PID 1 (the QEMU guest
# booted with systemd: tests/vm/vm-run --systemd), installed as `make install`
# installs it: into $(SYSTEMD_ROOT) here, copied into the guest's / there.
# Not under SANITIZE=1: the unit's MemoryMax= and mlockall() do not fit ASan.
SYSTEMD_TESTS := $(if $(filter 1,$(SANITIZE)),,$(filter %/test_systemd,$(TESTS)))
SYSTEMD_ROOT := $(BUILD)/systemd-root
$(SYSTEMD_ROOT).installed: $(PROGS) systemd/rmdd.service.in
	$(Q)rm -rf $(SYSTEMD_ROOT)
	$(Q)$(MAKE) --no-print-directory -s install DESTDIR=$(abspath $(SYSTEMD_ROOT)) \
		PREFIX=/usr SYSCONFDIR=/etc >/dev/null
	$(Q)touch $@

# bench/insn-guard.sh: the loop's instructions per cycle must not rise more
# than 5 % above the committed figure (callgrind counts; not a timing test).
# tests/package/check-install: `make install` into a scratch DESTDIR, used
# as a user would (tests/package/check-deb does it for the package).
# Sanitizer builds count their own instrumentation: not there.
# All of it runs with the venv's python3 first on PATH ($(VENV_PATH)); the
# runner's last lines count and list skips (CI=true: tests/expected-skips).
TEST_PATH = PATH="$(abspath $(VENV_PATH)):$$PATH"
test: all $(VENV_PATH)/python3 $(LCM_PYTHON) $(if $(SYSTEMD_TESTS),$(SYSTEMD_ROOT).installed)
	$(Q)$(TEST_PATH) BUILD=$(BUILD) tests/run-tests.sh --vcan $(VCAN_TESTS) --systemd $(SYSTEMD_TESTS) \
		-- $(TESTS) $(ROS2_TESTS) $(DOCS_TESTS)
ifneq ($(SANITIZE),1)
	$(Q)$(TEST_PATH) BUILD=$(BUILD) bench/insn-guard.sh
	$(Q)$(TEST_PATH) BUILD=$(BUILD) MAKE="$(MAKE)" tests/package/check-install
endif

# rmdd.service and the instances' template rmdd@.service, both from
# systemd/rmdd.service.in (one copy of every rule): $(call rmdd_unit,NAME,
# STATE,DESCRIPTION,UNIT) fills in the prefix, the configuration
# $(SYSCONFDIR)/rmdd/NAME.yaml, the StateDirectory= STATE and the
# Description='s tail.
define rmdd_unit
	sed -e 's|@BINDIR@|$(BINDIR)|g' -e 's|@SYSCONFDIR@|$(SYSCONFDIR)|g' -e 's|@NAME@|$(1)|g' \
		-e 's|@STATE@|$(2)|g' -e 's|@DESCRIPTION@|$(3)|g' \
		systemd/rmdd.service.in >$(DESTDIR)$(SYSTEMDUNITDIR)/$(4)
	chmod 0644 $(DESTDIR)$(SYSTEMDUNITDIR)/$(4)
endef

# ---- install (README.md "Install"; debian/rules packages `make install`) ----
# rmdd's systemd units (systemd also searches /usr/local/lib/systemd/system),
# its configuration (an existing one is never overwritten: a user's edits
# survive `make install`), and the examples: configurations, the example
# controllers and the systemd-networkd files that bring CAN interfaces up
# (copy them to /etc/systemd/network/ to use them).
SYSTEMDUNITDIR ?= $(PREFIX)/lib/systemd/system
LIBDIR ?= $(PREFIX)/lib
INCLUDEDIR ?= $(PREFIX)/include
DATADIR ?= $(PREFIX)/share
MANDIR ?= $(DATADIR)/man
DOCDIR ?= $(DATADIR)/doc/rmdd
EXAMPLESDIR ?= $(DOCDIR)/examples
JAVADIR ?= $(DATADIR)/java
LCMDIR ?= $(DATADIR)/rmdd/lcm
PKGCONFIGDIR ?= $(LIBDIR)/pkgconfig
# Debian's python3 reads /usr/lib/python3/dist-packages (packages) and
# /usr/local/lib/python3.X/dist-packages (everything else).
PYTHONDIR ?= $(if $(filter /usr,$(PREFIX)),/usr/lib/python3/dist-packages,$(PREFIX)/lib/$(shell \
	python3 -c 'import sys; print("python%d.%d" % sys.version_info[:2])')/dist-packages)
RMDD_CONF := $(DESTDIR)$(SYSCONFDIR)/rmdd/rmdd.yaml
RMDD_EXAMPLES := $(filter-out examples/physics,$(wildcard examples/*)) systemd/80-can.network \
	systemd/80-can.link
# the leg of docs/physics.md, in a folder of its own (its YAML names leg.xml beside it)
PHYSICS_EXAMPLES := $(wildcard examples/physics/*)
RMDD_DOCS := $(wildcard docs/*.md)

.PHONY: install-lcm install-man install-docs man deb

# The configuration's JSON Schema, from the loader's own tables (rmdd
# --schema): YAML editors validate and complete rmdd.yaml with it
# (docs/configuration.md "Editors"); tests/docs/check-schema checks it.
RMDD_SCHEMA := $(BUILD)/rmdd.schema.json
$(RMDD_SCHEMA): $(RMDD)
	@$(if $(Q),echo "  GEN     $@")
	$(Q)$(RMDD) --schema >$@.tmp && mv $@.tmp $@
all: $(RMDD_SCHEMA)

# The Python package's commands, PROGRAM:MODULE: each a wrapper in BINDIR that
# runs the installed module (PYTHONDIR) with $$RMD_PYTHON or the python3 on
# PATH: an active venv with lcm and the command's extra (Debian 12 has no
# python3-lcm; rmd-plot(1), docs/logs.md).
PY_TOOLS := rmd-plot:rmd.plot rmd-export:rmd.export rmd-foxglove:rmd.foxglove_live rmd-view:rmd.view
define py_wrapper
printf '%s\n' '#!/bin/sh' \
		'# $(1): the installed module $(2) ($(PYTHONDIR)), run by $$RMD_PYTHON' \
		'# or the python3 on PATH (a venv with lcm: Debian 12 has no python3-lcm).' \
		'PYTHONPATH="$(PYTHONDIR)$${PYTHONPATH:+:$$PYTHONPATH}" exec "$${RMD_PYTHON:-python3}" -m $(2) "$$@"' \
		>$(DESTDIR)$(BINDIR)/$(1) && chmod 0755 $(DESTDIR)$(BINDIR)/$(1)
	
endef

install: all install-lcm install-man install-docs
	install -D -m 0755 $(RMDCTL) $(DESTDIR)$(BINDIR)/rmdctl
	$(if $(RMDSIM_SRCS),install -D -m 0755 $(RMDSIM) $(DESTDIR)$(BINDIR)/rmd-sim)
	install -D -m 0755 $(RMDD) $(DESTDIR)$(BINDIR)/rmdd
	$(if $(MUJOCO_H),install -D -m 0644 $(PHYSICS_SO) $(DESTDIR)$(RMD_PHYSICS_DIR)/rmd-physics.so)
	install -D -m 0644 $(RMDD_SCHEMA) $(DESTDIR)$(DATADIR)/rmdd/rmdd.schema.json
	install -D -m 0755 src/tools/rmd-spy/rmd-spy $(DESTDIR)$(BINDIR)/rmd-spy
	$(if $(HAVE_DDS),install -D -m 0755 $(RMD_ROS2) $(DESTDIR)$(BINDIR)/rmd-ros2)
	install -d $(DESTDIR)$(SYSTEMDUNITDIR) $(DESTDIR)$(EXAMPLESDIR)
	$(call rmdd_unit,rmdd,rmdd,,rmdd.service)
	$(call rmdd_unit,%i,rmdd-%i, (instance %i),rmdd@.service)
	install -m 0644 systemd/rmdd-can@.service $(DESTDIR)$(SYSTEMDUNITDIR)/rmdd-can@.service
	install -m 0644 $(RMDD_EXAMPLES) $(DESTDIR)$(EXAMPLESDIR)/
	install -d $(DESTDIR)$(EXAMPLESDIR)/physics
	install -m 0644 $(PHYSICS_EXAMPLES) $(DESTDIR)$(EXAMPLESDIR)/physics/
	install -d $(DESTDIR)$(BASHCOMPDIR)
	install -m 0644 $(COMPLETIONS) $(DESTDIR)$(BASHCOMPDIR)/
	@if [ -e $(RMDD_CONF) ]; then \
		echo "install: kept the existing $(RMDD_CONF); the new example is $(DESTDIR)$(EXAMPLESDIR)/rmdd.yaml"; \
	else \
		echo "install -D -m 0644 examples/rmdd.yaml $(RMDD_CONF)"; \
		install -D -m 0644 examples/rmdd.yaml $(RMDD_CONF); \
	fi
	@echo "install: edit $(SYSCONFDIR)/rmdd/rmdd.yaml, then: systemctl daemon-reload && systemctl enable --now rmdd"

# The LCM types for controllers: the .lcm files; lcm-gen's C as headers
# <rmd/rmd_<type>.h> under $(INCLUDEDIR)/rmd_lcm, beside them the channel
# names (include/rmd/channels.h: string literals, no library), and a static library of
# position-independent objects, found by `pkg-config --cflags --libs
# rmd-lcm`; the jar for lcm-spy; the Python package `rmd` (types and
# rmd.Client; its `lcm` comes from PyPI: Debian 12 has no python3-lcm).
RMD_LCM_LIB := $(BUILD)/rmd-lcm/librmd-lcm.a
LCM_CHANNELS_HDR := include/rmd/channels.h
RMD_LCM_OBJS := $(GEN_SRCS:$(BUILD)/gen/%.c=$(BUILD)/rmd-lcm/%.o)

$(BUILD)/rmd-lcm/%.o: $(BUILD)/gen/%.c
	@mkdir -p $(dir $@)
	@$(if $(Q),echo "  CC      $< (PIC)")
	$(Q)$(CC) $(CPPFLAGS) $(CFLAGS) $(GEN_CFLAGS) -fPIC -c -o $@ $<

$(RMD_LCM_LIB): $(RMD_LCM_OBJS)
	@$(if $(Q),echo "  AR      $@")
	$(Q)rm -f $@ && $(AR) rcs $@ $^

install-lcm: $(RMD_LCM_LIB) $(LCM_JAVA) $(LCM_PYTHON)
	install -d $(DESTDIR)$(LCMDIR) $(DESTDIR)$(INCLUDEDIR)/rmd_lcm/rmd $(DESTDIR)$(PKGCONFIGDIR) \
		$(DESTDIR)$(PYTHONDIR)/rmd
	install -m 0644 $(LCM_TYPES) $(DESTDIR)$(LCMDIR)/
	install -m 0644 $(GEN_HDRS) $(LCM_CHANNELS_HDR) $(DESTDIR)$(INCLUDEDIR)/rmd_lcm/rmd/
	install -D -m 0644 $(RMD_LCM_LIB) $(DESTDIR)$(LIBDIR)/librmd-lcm.a
	printf '%s\n' 'includedir=$(INCLUDEDIR)' 'libdir=$(LIBDIR)' '' 'Name: rmd-lcm' \
		'Description: rmdd LCM types as lcm-gen C, included as rmd/rmd_<type>.h' \
		'Version: $(RMD_VERSION)' 'Requires: lcm' 'Cflags: -I$${includedir}/rmd_lcm' \
		'Libs: -L$${libdir} -lrmd-lcm' >$(DESTDIR)$(PKGCONFIGDIR)/rmd-lcm.pc
	install -D -m 0644 $(LCM_JAVA) $(DESTDIR)$(JAVADIR)/rmd-types.jar
	install -m 0644 $(BUILD)/python/rmd/*.py $(DESTDIR)$(PYTHONDIR)/rmd/
	install -d $(DESTDIR)$(BINDIR)
	$(foreach t,$(PY_TOOLS),$(call py_wrapper,$(firstword $(subst :, ,$(t))),$(lastword $(subst :, ,$(t)))))

# Man pages: help2man makes each program's page from its own --help (the
# options have one copy) and docs/man/<program>.h2m (description, files,
# examples, see also): rmdd(8), rmdctl(1), rmd-sim(1), rmd-spy(1),
# rmd-ros2(1) where it is built, and the Python tools (PY_TOOLS), whose
# --help needs neither lcm nor their extras (the package build's python3
# makes them); rmdd.yaml(5) is docs/man/rmdd.yaml.5.in around
# examples/rmdd.yaml.
HELP2MAN ?= help2man
PY_TOOL_NAMES := $(foreach t,$(PY_TOOLS),$(firstword $(subst :, ,$(t))))
PY_MAN_PAGES := $(PY_TOOL_NAMES:%=$(BUILD)/man/%.1)
MAN_PAGES := $(BUILD)/man/rmdd.8 $(BUILD)/man/rmdctl.1 $(BUILD)/man/rmd-sim.1 $(BUILD)/man/rmd-spy.1 \
	$(BUILD)/man/rmdd.yaml.5 $(PY_MAN_PAGES) $(if $(HAVE_DDS),$(BUILD)/man/rmd-ros2.1)
# the command help2man runs (with --help, --version): the program itself
MAN_CMD = $<
MAN_H2M = $(HELP2MAN) --no-info --no-discard-stderr --version-string='$(RMD_VERSION)' \
	--section=$(subst .,,$(suffix $@)) --include=$(filter %.h2m,$^) --output=$@ \
	"docs/man/gnu-help $(MAN_CMD)"

man: $(MAN_PAGES)

# a Python tool: its module (PY_TOOLS) from the build's copy of the package
$(PY_MAN_PAGES): MAN_CMD = env PYTHONPATH=$(BUILD)/python python3 -m \
	$(lastword $(subst :, ,$(filter $*:%,$(PY_TOOLS))))
$(PY_MAN_PAGES): $(BUILD)/man/%.1: docs/man/%.h2m docs/man/gnu-help $(LCM_PYTHON)
	@mkdir -p $(dir $@)
	@$(if $(Q),echo "  MAN     $@")
	$(Q)$(MAN_H2M)

$(BUILD)/man/%.1: $(BUILD)/% docs/man/%.h2m docs/man/gnu-help
	@mkdir -p $(dir $@)
	@$(if $(Q),echo "  MAN     $@")
	$(Q)$(MAN_H2M)

# rmd-spy is a script of the tree, not a build product
$(BUILD)/man/rmd-spy.1: src/tools/rmd-spy/rmd-spy docs/man/rmd-spy.h2m docs/man/gnu-help
	@mkdir -p $(dir $@)
	@$(if $(Q),echo "  MAN     $@")
	$(Q)$(MAN_H2M)

$(BUILD)/man/%.8: $(BUILD)/% docs/man/%.h2m docs/man/gnu-help
	@mkdir -p $(dir $@)
	@$(if $(Q),echo "  MAN     $@")
	$(Q)$(MAN_H2M)

# examples/rmdd.yaml as roff text: backslashes and minus signs escaped, a
# leading . or ' made literal.
$(BUILD)/man/rmdd.yaml.5: docs/man/rmdd.yaml.5.in examples/rmdd.yaml
	@mkdir -p $(dir $@)
	@$(if $(Q),echo "  MAN     $@")
	$(Q)sed -e 's/\\/\\e/g' -e 's/-/\\-/g' -e "s/^[.']/\\\\\&&/" examples/rmdd.yaml >$@.yaml
	$(Q)sed -e '/^@EXAMPLE@$$/{r $@.yaml' -e 'd;}' -e 's/@VERSION@/$(RMD_VERSION)/g' $< >$@
	$(Q)rm -f $@.yaml

install-man: $(MAN_PAGES)
	install -d $(DESTDIR)$(MANDIR)/man1 $(DESTDIR)$(MANDIR)/man5 $(DESTDIR)$(MANDIR)/man8
	install -m 0644 $(filter %.1,$(MAN_PAGES)) $(DESTDIR)$(MANDIR)/man1/
	install -m 0644 $(filter %.5,$(MAN_PAGES)) $(DESTDIR)$(MANDIR)/man5/
	install -m 0644 $(filter %.8,$(MAN_PAGES)) $(DESTDIR)$(MANDIR)/man8/

# README.md, LICENSE and docs/ keep their relative places (the README's
# links hold); the examples go beside them (EXAMPLESDIR).
install-docs:
	install -d $(DESTDIR)$(DOCDIR)/docs $(DESTDIR)$(DOCDIR)/python
	install -m 0644 README.md LICENSE $(DESTDIR)$(DOCDIR)/
	install -m 0644 $(RMDD_DOCS) $(DESTDIR)$(DOCDIR)/docs/
	install -m 0644 python/README.md $(DESTDIR)$(DOCDIR)/python/

uninstall:
	rm -f $(DESTDIR)$(BINDIR)/rmdctl $(DESTDIR)$(BINDIR)/rmd-sim $(DESTDIR)$(BINDIR)/rmdd $(DESTDIR)$(BINDIR)/rmd-spy
	rm -f $(addprefix $(DESTDIR)$(BINDIR)/,$(PY_TOOL_NAMES))
	rm -f $(DESTDIR)$(MANDIR)/man1/rmd-ros2.1
	rm -f $(DESTDIR)$(BINDIR)/rmd-ros2 $(DESTDIR)$(RMD_PHYSICS_DIR)/rmd-physics.so
	[ ! -d $(DESTDIR)$(RMD_PHYSICS_DIR) ] || rmdir --ignore-fail-on-non-empty $(DESTDIR)$(RMD_PHYSICS_DIR)
	rm -f $(DESTDIR)$(SYSTEMDUNITDIR)/rmdd.service $(DESTDIR)$(SYSTEMDUNITDIR)/rmdd@.service \
		$(DESTDIR)$(SYSTEMDUNITDIR)/rmdd-can@.service
	rm -f $(addprefix $(DESTDIR)$(EXAMPLESDIR)/,$(notdir $(RMDD_EXAMPLES)))
	rm -f $(addprefix $(DESTDIR)$(EXAMPLESDIR)/physics/,$(notdir $(PHYSICS_EXAMPLES)))
	[ ! -d $(DESTDIR)$(EXAMPLESDIR)/physics ] || rmdir --ignore-fail-on-non-empty $(DESTDIR)$(EXAMPLESDIR)/physics
	rm -f $(addprefix $(DESTDIR)$(BASHCOMPDIR)/,$(notdir $(COMPLETIONS)))
	rm -f $(addprefix $(DESTDIR)$(MANDIR)/,$(foreach m,$(MAN_PAGES),man$(subst .,,$(suffix $(m)))/$(notdir $(m))))
	rm -rf $(DESTDIR)$(LCMDIR) $(DESTDIR)$(DATADIR)/rmdd/rmdd.schema.json $(DESTDIR)$(INCLUDEDIR)/rmd_lcm $(DESTDIR)$(PYTHONDIR)/rmd $(DESTDIR)$(DOCDIR)
	rm -f $(DESTDIR)$(LIBDIR)/librmd-lcm.a $(DESTDIR)$(PKGCONFIGDIR)/rmd-lcm.pc $(DESTDIR)$(JAVADIR)/rmd-types.jar
	-rmdir $(DESTDIR)$(DATADIR)/rmdd 2>/dev/null
	@echo "uninstall: kept $(RMDD_CONF) (your configuration); remove it by hand"

# `make deb`: the Debian packages rmdd and rmdd-dev, in $(BUILD)/deb
# (debian/README.source).  dpkg-buildpackage runs in a copy of the tree;
# when RMD_VERSION is not the release debian/changelog's top entry names, the
# copy's changelog gets an entry for it on top (RMD_VERSION is a Debian
# version as it is: tools/version).  Its debian/copyright is LICENSE.  The
# package build sees none of this make's variables, nor the caller's
# environment (env -i): debian/rules sets its own.
DEB_VERSION = $(RMD_VERSION)
DEB_SRC := $(BUILD)/deb/rmdd

# `make -s version`: the version this tree builds (tools/version).
.PHONY: version
version:
	@echo '$(RMD_VERSION)'

deb:
	rm -rf $(BUILD)/deb && mkdir -p $(DEB_SRC)
	tar -c --exclude=./build --exclude=./.git --exclude=./debian/rmdd --exclude=__pycache__ \
		--exclude=./python/build --exclude='./python/*.egg-info' . | tar -x -C $(DEB_SRC)
	if [ "$$(dpkg-parsechangelog -S Version -l debian/changelog)" != '$(DEB_VERSION)' ]; then \
		{ printf 'rmdd (%s) unstable; urgency=medium\n\n  * Built by make deb from %s.\n\n -- %s  %s\n\n' \
			'$(DEB_VERSION)' "$$(git log -1 --format=%h 2>/dev/null || echo 'a tree without history')" \
			"$$(sed -n 's/^Maintainer: //p' debian/control)" \
			"$$(date -R -d @$$(git log -1 --format=%ct 2>/dev/null || date +%s))"; \
		  cat debian/changelog; } >$(DEB_SRC)/debian/changelog; fi
	{ printf '%s\n' 'Format: https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/' \
		'Upstream-Name: rmdd' '' 'Files: *' 'Copyright: 2026 The rmdd authors' 'License: Expat' '' \
		'License: Expat'; sed -n -e '/^Permission/,$$s/^$$/./' -e '/^Permission/,$$s/^/ /p' LICENSE; } \
		>$(DEB_SRC)/debian/copyright
	cd $(DEB_SRC) && env -i PATH="$$PATH" HOME="$$HOME" LANG=C.UTF-8 RMD_VERSION='$(RMD_VERSION)' \
		$${DEB_BUILD_OPTIONS:+DEB_BUILD_OPTIONS="$$DEB_BUILD_OPTIONS"} dpkg-buildpackage -b -us -uc --jobs=auto
	@ls $(BUILD)/deb/*.deb

FORMAT_SRCS = $(shell find src include tests bench examples -name '*.[ch]' 2>/dev/null)

format:
	$(CLANG_FORMAT) -i $(FORMAT_SRCS)

# Includes point down the layers, no include circle, and nothing outside the
# bus layer names a transport (tests/check-layers says what it checks).
check-layers:
	$(Q)tests/check-layers . && tests/check-layers --selftest

format-check:
	$(Q)$(CLANG_FORMAT) --dry-run -Werror $(FORMAT_SRCS) && echo "format-check: ok"

# ---- fuzzing (tests/fuzz/README.md) -------------------------------------------------------
# Every harness tests/fuzz/fuzz_<name>.c is linked with libFuzzer against the
# library (and the program objects it needs) built again by clang with
# ASan, UBSan and float-cast-overflow, into $(FUZZ_DIR).  `make fuzz` builds
# them and runs each for FUZZ_SECONDS on its corpus (tests/fuzz/run); a
# crash, leak, sanitizer report or timeout fails it.  Debian 12: clang and
# libclang-rt-dev (libclang_rt.fuzzer), in DEB_PACKAGES.
FUZZ_CC ?= clang
FUZZ_DIR := build/fuzz
FUZZ_SECONDS ?= 10
FUZZ_SAN := -fsanitize=address,undefined,float-cast-overflow -fno-omit-frame-pointer
FUZZ_CFLAGS := -O1 -g -std=gnu11 $(WARN) $(FUZZ_SAN) -fsanitize=fuzzer-no-link \
	-Iinclude -Isrc -I$(BUILD)/gen $(PKG_CFLAGS) -MMD -MP
FUZZ_SRCS := $(wildcard tests/fuzz/fuzz_*.c)
FUZZERS := $(FUZZ_SRCS:tests/fuzz/%.c=$(FUZZ_DIR)/%)
FUZZ_LIB := $(FUZZ_DIR)/librmd.a
FUZZ_LIB_OBJS := $(LIB_SRCS:%.c=$(FUZZ_DIR)/obj/%.o) $(GEN_SRCS:%.c=$(FUZZ_DIR)/obj/%.o)

.PHONY: fuzz fuzz-build

$(FUZZ_DIR)/obj/%.o: %.c | $(GEN_HDRS)
	@mkdir -p $(dir $@)
	@$(if $(Q),echo "  FUZZCC  $<")
	$(Q)$(FUZZ_CC) $(FUZZ_CFLAGS) -c -o $@ $<

# lcm-gen's C is sanitized but not coverage-guided: its byte loops are not
# ours to explore, and cost the bridge harness most of its speed.
$(FUZZ_DIR)/obj/$(BUILD)/gen/%.o: $(BUILD)/gen/%.c | $(GEN_HDRS)
	@mkdir -p $(dir $@)
	@$(if $(Q),echo "  FUZZCC  $<")
	$(Q)$(FUZZ_CC) $(filter-out -fsanitize=fuzzer-no-link -O1,$(FUZZ_CFLAGS)) -O2 $(GEN_CFLAGS) -c -o $@ $<

$(FUZZ_LIB): $(FUZZ_LIB_OBJS)
	@$(if $(Q),echo "  AR      $@")
	$(Q)rm -f $@ && $(AR) rcs $@ $^

$(FUZZ_DIR)/fuzz_%: $(FUZZ_DIR)/obj/tests/fuzz/fuzz_%.o $(FUZZ_DIR)/obj/tests/fuzz/common.o $(FUZZ_LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(FUZZ_CC) $(FUZZ_SAN) -fsanitize=fuzzer -o $@ $(filter %.o,$^) $(filter %.a,$^) $(LIBS)

# rmd-sim's config reader is a program file: linked in as test_sim_params does.
$(FUZZ_DIR)/fuzz_sim_config: $(FUZZ_DIR)/obj/src/tools/rmd-sim/config.o

fuzz-build: $(FUZZERS)

fuzz: fuzz-build
	$(Q)FUZZ_DIR=$(FUZZ_DIR) tests/fuzz/run --seconds $(FUZZ_SECONDS) $(notdir $(FUZZERS))

clean:
	rm -rf build python/build python/rmd.egg-info

-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)
