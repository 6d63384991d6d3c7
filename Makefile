# wpd - Weighted Poisson-disk resampling of huge point clouds.
# Targets: all (./wpd), test, demo, bench, install PREFIX=..., clean, deps.

CC      ?= gcc
CFLAGS  ?= -O2 -g
CFLAGS  += -std=c11 -D_GNU_SOURCE -Wall -Wextra -fopenmp -Isrc -Itools
LDLIBS  += -lzstd -lpng -lm
LDFLAGS += -fopenmp
PREFIX  ?= /usr/local

# Every .c under src/ and tools/ except the program entry point goes into a
# static library shared by the program and the unit tests.
LIB_SRC  := $(filter-out src/cli/main.c,$(wildcard src/*/*.c tools/*.c))
LIB_OBJ  := $(LIB_SRC:%.c=build/%.o)
MAIN_OBJ := build/src/cli/main.o
TEST_SRC := $(wildcard tests/unit/*.c)
TEST_OBJ := $(TEST_SRC:%.c=build/%.o)

# Debian packages needed to build and test.
DEB_PKGS := gcc make libzstd-dev libpng-dev libc6-dev python3 python3-numpy bc

.PHONY: all test demo bench install clean deps

all: wpd

wpd: $(MAIN_OBJ) build/libwpd.a
	$(CC) $(LDFLAGS) -o $@ $^ $(LDLIBS)

build/libwpd.a: $(LIB_OBJ)
	ar rcs $@ $^

build/%.o: %.c
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) -MMD -MP -c -o $@ $<

build/unit_tests: $(TEST_OBJ) build/libwpd.a
	$(CC) $(LDFLAGS) -o $@ $^ $(LDLIBS)

# Spill format measurements (bench/spill.sh); includes src/ooc/spill.c.
build/spill_bench: bench/spill_bench.c src/ooc/spill.c build/libwpd.a
	$(CC) $(CFLAGS) $(LDFLAGS) -o $@ $< build/libwpd.a $(LDLIBS)

-include $(LIB_OBJ:.o=.d) $(MAIN_OBJ:.o=.d) $(TEST_OBJ:.o=.d)

# Installs the missing Debian build packages when run as root; otherwise
# only reports what is missing.
deps:
	@missing=""; for p in $(DEB_PKGS); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then \
	    echo "deps: installing$$missing"; \
	    apt-get update -q >/dev/null && DEBIAN_FRONTEND=noninteractive apt-get install -y -q $$missing >/dev/null; \
	  else echo "deps: missing$$missing (run 'make deps' as root)"; exit 1; fi; \
	fi

test: deps
	$(MAKE) wpd build/unit_tests
	tests/run.sh

demo: deps
	$(MAKE) wpd
	tests/demo.sh

bench: deps
	$(MAKE) wpd
	bench/run.sh

install: wpd
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(PREFIX)/share/man/man1
	install -m 755 wpd $(DESTDIR)$(PREFIX)/bin/wpd
	if [ -f docs/wpd.1 ]; then install -m 644 docs/wpd.1 $(DESTDIR)$(PREFIX)/share/man/man1/wpd.1; fi

clean:
	rm -rf build wpd
