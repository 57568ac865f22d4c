# rmdd — one non-recursive Makefile (STYLE.md "Build").
#
#   make                 build the library, tools and test binaries
#   make test            run every cmocka suite (tests/run-tests.sh)
#   make install         PREFIX=/usr/local DESTDIR=
#   make format-check    clang-format, kernel layout
#   SANITIZE=1           ASan + UBSan (objects go to build/san)
#   WERROR=1             warnings are errors (CI sets it)
#   V=1                  echo every command

PREFIX ?= /usr/local
BINDIR ?= $(PREFIX)/bin
SYSCONFDIR ?= /etc
DESTDIR ?=

CC ?= cc
CLANG_FORMAT ?= clang-format
CFLAGS ?= -O2 -g

ifeq ($(SANITIZE),1)
BUILD ?= build/san
SAN_FLAGS := -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all
else
BUILD ?= build
SAN_FLAGS :=
endif

WARN := -Wall -Wextra -Wshadow -Wstrict-prototypes -Wmissing-prototypes -Wformat=2 \
	-Wswitch-enum -Wvla
# CI (CI=true) builds with -Werror.
ifeq ($(CI),true)
WERROR ?= 1
endif
ifeq ($(WERROR),1)
WARN += -Werror
endif
HARDEN := -D_FORTIFY_SOURCE=2 -fstack-protector-strong -fPIE

PKGS := libmodbus libcyaml yaml-0.1
PKG_CFLAGS := $(shell pkg-config --cflags $(PKGS) 2>/dev/null)
PKG_LIBS := $(shell pkg-config --libs $(PKGS) 2>/dev/null)

override CFLAGS += -std=gnu11 $(WARN) $(HARDEN) $(SAN_FLAGS) -Iinclude -I$(BUILD)/gen $(PKG_CFLAGS) -MMD -MP
override LDFLAGS += -pie -Wl,-z,relro,-z,now $(SAN_FLAGS)

ifeq ($(V),1)
Q :=
else
Q := @
endif

# Layers 1..: every src/*.c is a library module; src/tools/*.c are programs.
LIB_SRCS := $(wildcard src/*.c)
LIB_OBJS := $(LIB_SRCS:%.c=$(BUILD)/%.o)
LIB := $(BUILD)/librmd.a

# Each program is src/tools/<name>.c plus its src/tools/<name>_*.c parts.
RMDCTL_SRCS := $(wildcard src/tools/rmdctl*.c)
RMDCTL := $(BUILD)/rmdctl
RMDSIM_SRCS := $(wildcard src/tools/rmd-sim*.c)
RMDSIM := $(BUILD)/rmd-sim
RMDD_SRCS := $(wildcard src/tools/rmdd*.c)
RMDD := $(BUILD)/rmdd
PROGS := $(if $(RMDCTL_SRCS),$(RMDCTL)) $(if $(RMDSIM_SRCS),$(RMDSIM)) $(if $(RMDD_SRCS),$(RMDD))

TEST_SRCS := $(wildcard tests/test_*.c)
TESTS := $(TEST_SRCS:tests/%.c=$(BUILD)/tests/%)
TEST_LIBS := -lcmocka

LIBS := $(PKG_LIBS) -lm

.PHONY: all test install uninstall format format-check clean deps
.SECONDARY:

# Debian/Ubuntu packages needed to build, test and run (`sudo make deps`).
DEB_PACKAGES := build-essential pkg-config clang-format libcmocka-dev libmodbus-dev \
	libcyaml-dev libyaml-dev can-utils python3

deps:
	apt-get update -qq
	DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $(DEB_PACKAGES)
all: $(LIB) $(PROGS) $(TESTS)

$(BUILD)/%.o: %.c
	@mkdir -p $(dir $@)
	@$(if $(Q),echo "  CC      $<")
	$(Q)$(CC) $(CPPFLAGS) $(CFLAGS) -c -o $@ $<

$(LIB): $(LIB_OBJS)
	@$(if $(Q),echo "  AR      $@")
	$(Q)rm -f $@ && $(AR) rcs $@ $^

$(RMDCTL): $(RMDCTL_SRCS:%.c=$(BUILD)/%.o) $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

$(RMDSIM): $(RMDSIM_SRCS:%.c=$(BUILD)/%.o) $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

$(RMDD): $(RMDD_SRCS:%.c=$(BUILD)/%.o) $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

$(BUILD)/tests/%: $(BUILD)/tests/%.o $(LIB)
	@$(if $(Q),echo "  LD      $@")
	$(Q)$(CC) $(LDFLAGS) -o $@ $^ $(TEST_LIBS) $(LIBS)

test: all
	$(Q)BUILD=$(BUILD) tests/run-tests.sh $(TESTS)

install: all
	install -D -m 0755 $(RMDCTL) $(DESTDIR)$(BINDIR)/rmdctl
	$(if $(RMDSIM_SRCS),install -D -m 0755 $(RMDSIM) $(DESTDIR)$(BINDIR)/rmd-sim)

uninstall:
	rm -f $(DESTDIR)$(BINDIR)/rmdctl $(DESTDIR)$(BINDIR)/rmd-sim

FORMAT_SRCS = $(shell find src include tests bench examples -name '*.[ch]' 2>/dev/null)

format:
	$(CLANG_FORMAT) -i $(FORMAT_SRCS)

format-check:
	$(Q)$(CLANG_FORMAT) --dry-run -Werror $(FORMAT_SRCS) && echo "format-check: ok"

clean:
	rm -rf build

-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)
