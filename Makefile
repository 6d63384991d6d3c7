# wpd - Weighted Poisson-disk resampling of huge point clouds.
# Targets: all (./wpd), test, test-full, demo, bench, install PREFIX=..., clean, deps.

CC      ?= gcc
CFLAGS  ?= -O2 -g
CFLAGS  += -std=c11 -D_GNU_SOURCE -Wall -Wextra -fopenmp -Isrc -I.
LDLIBS  += -lzstd -lpng -lm
LDFLAGS += -fopenmp
PREFIX  ?= /usr/local

# Every .c under src/ and tools/ except the program entry point and the MPI
# ranks goes into a static library shared by the program and the unit tests
# (with the one-rank src/par/par_single.c).
LIB_SRC  := $(filter-out src/cli/main.c src/par/par_mpi.c,\
              $(wildcard src/*/*.c src/*/*/*.c tools/*/*.c))
LIB_OBJ  := $(LIB_SRC:%.c=build/%.o)
MAIN_OBJ := build/src/cli/main.o
TEST_SRC := $(wildcard tests/unit/*.c)
TEST_OBJ := $(TEST_SRC:%.c=build/%.o)

# Debian packages needed to build and test (Open MPI for the MPI build and
# its tests).
DEB_PKGS := gcc make libzstd-dev libpng-dev libc6-dev python3 python3-numpy bc \
            openmpi-bin libopenmpi-dev python3-pytest python3-pytest-xdist cmake g++
JOBS     ?= $(shell nproc 2>/dev/null || echo 2)

.PHONY: all test test-full test-build demo bench install clean deps lazperf laszip

all: wpd

wpd: $(MAIN_OBJ) build/libwpd.a
	$(CC) $(LDFLAGS) -o $@ $^ $(LDLIBS)

# `make MPI=1` builds wpd-mpi beside wpd (docs/scale-out.md): the same
# program with the ranks of src/par/par_mpi.c, linked before the library so
# that the one-rank par_single.o in it is not pulled in.
MPICC ?= mpicc
ifeq ($(MPI),1)
all: wpd-mpi
endif
wpd-mpi: $(MAIN_OBJ) build/mpi/par_mpi.o build/libwpd.a
	$(MPICC) $(LDFLAGS) -o $@ $^ $(LDLIBS)

build/mpi/par_mpi.o: src/par/par_mpi.c
	@mkdir -p $(dir $@)
	$(MPICC) $(CFLAGS) -MMD -MP -c -o $@ $<

# Made anew each time: ar would keep the objects of deleted sources.
build/libwpd.a: $(LIB_OBJ)
	rm -f $@
	ar rcs $@ $^

build/%.o: %.c
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) -MMD -MP -c -o $@ $<

build/unit_tests: $(TEST_OBJ) build/libwpd.a
	$(CC) $(LDFLAGS) -o $@ $^ $(LDLIBS)

# Spill format measurements (bench/spill.sh); links the spill library
# (src/spill/) from build/libwpd.a like the program.
build/spill_bench: bench/spill_bench.c build/libwpd.a
	$(CC) $(CFLAGS) $(LDFLAGS) -o $@ $< build/libwpd.a $(LDLIBS)

# LAZ decode speed on 1..T threads (bench/laz.sh).
build/laz_bench: bench/laz_bench.c build/libwpd.a
	$(CC) $(CFLAGS) $(LDFLAGS) -o $@ $< build/libwpd.a $(LDLIBS)

-include $(LIB_OBJ:.o=.d) $(MAIN_OBJ:.o=.d) $(TEST_OBJ:.o=.d) build/mpi/par_mpi.d

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

# The test tiers (docs/testing.md): `make test` the fast one, `make
# test-full` every test.
test-build: deps lazperf laszip
	$(MAKE) -j$(JOBS) wpd build/unit_tests
	if command -v $(MPICC) >/dev/null; then $(MAKE) -j$(JOBS) wpd-mpi; fi

test: test-build
	tests/run.sh fast

test-full: test-build
	tests/run.sh full

# laz-perf 0.0.7 (npm), the independent LAZ decoder the tests cross-check our
# LAZ output with (../shared/tools/laz2las.js), in build/npm. Best effort:
# without npm or the registry the tests say SKIP for those checks.
LAZPERF_DIR := build/npm
lazperf:
	@if [ -d $(LAZPERF_DIR)/node_modules/laz-perf ]; then :; \
	elif command -v npm >/dev/null; then \
	  mkdir -p $(LAZPERF_DIR) && npm install -s --no-audit --no-fund --prefix $(LAZPERF_DIR) laz-perf@0.0.7 >/dev/null || \
	  echo "lazperf: npm could not install laz-perf; the laz2las.js checks will SKIP"; \
	else echo "lazperf: no npm; the laz2las.js checks will SKIP"; fi

# LASzip, the reference LAZ implementation the tests compare our LAZ with
# both ways (tests/e2e/test_laz_laszip.py) and bench/laz.sh times, built
# once from ../shared/tools/laszip (its sources and build.sh) into
# build/laszip. Best effort: without cmake, g++ or the sources those tests
# SKIP.
LASZIP_SRC := ../shared/tools/laszip
LASZIP_DIR := build/laszip
laszip:
	@if [ -x $(LASZIP_DIR)/laszip_dump ] && [ -x $(LASZIP_DIR)/laszip_enc ] && \
	    [ -x $(LASZIP_DIR)/laszip_dec ]; then :; \
	elif [ ! -x $(LASZIP_SRC)/build.sh ]; then \
	  echo "laszip: no $(LASZIP_SRC)/build.sh; the LASzip checks will SKIP"; \
	elif ! command -v cmake >/dev/null || ! command -v g++ >/dev/null; then \
	  echo "laszip: no cmake or g++; the LASzip checks will SKIP"; \
	else echo "laszip: building LASzip into $(LASZIP_DIR) (about a minute)"; \
	  $(LASZIP_SRC)/build.sh $(LASZIP_DIR) >/dev/null || \
	  echo "laszip: the build failed (see $(LASZIP_DIR)/cmake.log); the LASzip checks will SKIP"; \
	fi

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
	rm -rf build wpd wpd-mpi

# ---- Hardening: fuzzing and sanitizer builds (docs/hardening.md) ----------
# make fuzz [FUZZ_RUNS=N]  libFuzzer targets for the PLY, LAS and LAZ readers and
#                          the spill codec, one after the other on one core,
#                          seeded from the data (the codec: generated seeds)
# make fuzz-smoke          the same for FUZZ_SMOKE_RUNS executions (CI)
# make test-asan           the whole suite against ASan+UBSan builds
# Separate build trees (build/fuzz, build/asan): never mixed with build/.

FUZZ_CC         ?= clang
FUZZ_DIR        := build/fuzz
FUZZ_RUNS       ?= 10000000
FUZZ_SMOKE_RUNS ?= 20000
FUZZ_MAX_LEN    ?= 65536
FUZZ_DATA       ?= $(or $(WPD_TEST_DATA),../shared/data)
FUZZ_DEB_PKGS   := clang libclang-rt-14-dev python3 bc
FUZZ_SAN        := -fsanitize=address,undefined -fno-sanitize-recover=undefined
FUZZ_CFLAGS     := -O1 -g -fno-omit-frame-pointer -std=c11 -D_GNU_SOURCE -Wall -Wextra \
                   -Isrc $(FUZZ_SAN)
# Only what the readers need, compiled without OpenMP (the readers are
# serial; clang's -fopenmp would need libomp-dev for nothing).
FUZZ_LIB_SRC    := src/io/reader.c src/io/schema.c src/io/batch.c src/io/record_cache.c \
                   src/io/decimal.c \
                   src/io/las/las_read.c src/io/las/las_schema.c \
                   src/io/laz/laz_vlr.c src/io/laz/laz_read.c src/io/laz/laz_items.c \
                   src/io/laz/laz_layered.c src/io/laz/laz_point14.c src/io/laz/laz_items14.c \
                   src/io/laz/laz_encoder.c src/io/laz/laz_items_enc.c \
                   src/io/laz/laz_point14_enc.c src/io/laz/laz_coder.c \
                   src/io/ply/ply_read.c src/io/ply/ply_header.c src/io/ply/ply_stream.c \
                   src/common/error.c src/common/fullio.c src/common/warnings.c
FUZZ_LIB_OBJ    := $(FUZZ_LIB_SRC:%.c=$(FUZZ_DIR)/%.o)
# The spill codec is pure (no I/O, no threads): its two files and errors.
FUZZ_CODEC_SRC  := src/spill/codec.c src/spill/planes.c src/common/error.c
FUZZ_CODEC_OBJ  := $(FUZZ_CODEC_SRC:%.c=$(FUZZ_DIR)/%.o)
# A collection's state parser (docs/ingest.md): the state, its JSON and errors.
FUZZ_COLL_SRC   := src/resample/collection.c src/resample/collection_parse.c \
                   src/common/error.c src/common/json.c src/common/fullio.c
FUZZ_COLL_OBJ   := $(FUZZ_COLL_SRC:%.c=$(FUZZ_DIR)/%.o)
FUZZ_TARGETS    := $(FUZZ_DIR)/fuzz_ply $(FUZZ_DIR)/fuzz_las $(FUZZ_DIR)/fuzz_laz \
                   $(FUZZ_DIR)/fuzz_spill_codec $(FUZZ_DIR)/fuzz_collection

ASAN_DIR        := build/asan
ASAN_SAN        := -fsanitize=address,undefined -fno-omit-frame-pointer \
                   -fno-sanitize-recover=undefined
ASAN_LIB_OBJ    := $(LIB_SRC:%.c=$(ASAN_DIR)/%.o)
ASAN_MAIN_OBJ   := $(ASAN_DIR)/src/cli/main.o
ASAN_TEST_OBJ   := $(TEST_SRC:%.c=$(ASAN_DIR)/%.o)

.PHONY: fuzz fuzz-smoke fuzz-deps fuzz-build fuzz-seeds test-asan asan-build

fuzz-deps:
	@$(MAKE) --no-print-directory deps DEB_PKGS="$(FUZZ_DEB_PKGS)"

$(FUZZ_DIR)/%.o: %.c
	@mkdir -p $(dir $@)
	$(FUZZ_CC) $(FUZZ_CFLAGS) $(FUZZ_COV_$(notdir $*)) -fsanitize=fuzzer-no-link -MMD -MP -c -o $@ $<

# The LAZ models' update loops (laz_coder.c) compare counts, never input
# bytes: tracing those comparisons took two thirds of the LAZ target's time
# and guides no mutation. Edge coverage and the sanitizers stay.
FUZZ_COV_laz_coder := -fno-sanitize-coverage=trace-cmp

$(FUZZ_DIR)/fuzz_ply: tests/fuzz/fuzz_reader.c tests/fuzz/drive.h $(FUZZ_LIB_OBJ)
	$(FUZZ_CC) $(FUZZ_CFLAGS) -fsanitize=fuzzer -DFUZZ_PLY -o $@ $< $(FUZZ_LIB_OBJ) -lm

$(FUZZ_DIR)/fuzz_las: tests/fuzz/fuzz_reader.c tests/fuzz/drive.h $(FUZZ_LIB_OBJ)
	$(FUZZ_CC) $(FUZZ_CFLAGS) -fsanitize=fuzzer -DFUZZ_LAS -o $@ $< $(FUZZ_LIB_OBJ) -lm

$(FUZZ_DIR)/fuzz_laz: tests/fuzz/fuzz_reader.c tests/fuzz/drive.h $(FUZZ_LIB_OBJ)
	$(FUZZ_CC) $(FUZZ_CFLAGS) -fsanitize=fuzzer -DFUZZ_LAZ -o $@ $< $(FUZZ_LIB_OBJ) -lm

$(FUZZ_DIR)/fuzz_spill_codec: tests/fuzz/fuzz_spill_codec.c $(FUZZ_CODEC_OBJ)
	$(FUZZ_CC) $(FUZZ_CFLAGS) -fsanitize=fuzzer -o $@ $< $(FUZZ_CODEC_OBJ) -lm

$(FUZZ_DIR)/fuzz_collection: tests/fuzz/fuzz_collection.c $(FUZZ_COLL_OBJ)
	$(FUZZ_CC) $(FUZZ_CFLAGS) -fsanitize=fuzzer -o $@ $< $(FUZZ_COLL_OBJ) -lm

fuzz-build: fuzz-deps
	@$(MAKE) --no-print-directory $(FUZZ_TARGETS)

fuzz-seeds:
	python3 tests/fuzz/make_seeds.py $(FUZZ_DATA) $(FUZZ_DIR)/seeds $(FUZZ_MAX_LEN)
	python3 tests/fuzz/make_codec_seeds.py $(FUZZ_DIR)/seeds/codec
	python3 tests/fuzz/make_collection_seeds.py $(FUZZ_DIR)/seeds/collection

fuzz: fuzz-build fuzz-seeds
	tests/fuzz/run.sh $(FUZZ_DIR)/fuzz_ply $(FUZZ_DIR)/seeds/ply $(FUZZ_DIR)/ply $(FUZZ_RUNS) $(FUZZ_MAX_LEN)
	tests/fuzz/run.sh $(FUZZ_DIR)/fuzz_las $(FUZZ_DIR)/seeds/las $(FUZZ_DIR)/las $(FUZZ_RUNS) $(FUZZ_MAX_LEN)
	tests/fuzz/run.sh $(FUZZ_DIR)/fuzz_laz $(FUZZ_DIR)/seeds/laz $(FUZZ_DIR)/laz $(FUZZ_RUNS) $(FUZZ_MAX_LEN)
	tests/fuzz/run.sh $(FUZZ_DIR)/fuzz_spill_codec $(FUZZ_DIR)/seeds/codec $(FUZZ_DIR)/codec $(FUZZ_RUNS) $(FUZZ_MAX_LEN)
	tests/fuzz/run.sh $(FUZZ_DIR)/fuzz_collection $(FUZZ_DIR)/seeds/collection $(FUZZ_DIR)/collection $(FUZZ_RUNS) $(FUZZ_MAX_LEN)

# Fresh corpora and a fixed seed: the same executions on every CI run.
fuzz-smoke: fuzz-build fuzz-seeds
	rm -rf $(FUZZ_DIR)/smoke
	tests/fuzz/run.sh $(FUZZ_DIR)/fuzz_ply $(FUZZ_DIR)/seeds/ply $(FUZZ_DIR)/smoke/ply $(FUZZ_SMOKE_RUNS) $(FUZZ_MAX_LEN) 1
	tests/fuzz/run.sh $(FUZZ_DIR)/fuzz_las $(FUZZ_DIR)/seeds/las $(FUZZ_DIR)/smoke/las $(FUZZ_SMOKE_RUNS) $(FUZZ_MAX_LEN) 1
	tests/fuzz/run.sh $(FUZZ_DIR)/fuzz_laz $(FUZZ_DIR)/seeds/laz $(FUZZ_DIR)/smoke/laz $(FUZZ_SMOKE_RUNS) $(FUZZ_MAX_LEN) 1
	tests/fuzz/run.sh $(FUZZ_DIR)/fuzz_spill_codec $(FUZZ_DIR)/seeds/codec $(FUZZ_DIR)/smoke/codec $(FUZZ_SMOKE_RUNS) $(FUZZ_MAX_LEN) 1
	tests/fuzz/run.sh $(FUZZ_DIR)/fuzz_collection $(FUZZ_DIR)/seeds/collection $(FUZZ_DIR)/smoke/collection $(FUZZ_SMOKE_RUNS) $(FUZZ_MAX_LEN) 1

$(ASAN_DIR)/%.o: %.c
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) $(ASAN_SAN) -MMD -MP -c -o $@ $<

$(ASAN_DIR)/libwpd.a: $(ASAN_LIB_OBJ)
	rm -f $@
	ar rcs $@ $^

$(ASAN_DIR)/wpd: $(ASAN_MAIN_OBJ) $(ASAN_DIR)/libwpd.a
	$(CC) $(LDFLAGS) $(ASAN_SAN) -o $@ $^ $(LDLIBS)

$(ASAN_DIR)/unit_tests: $(ASAN_TEST_OBJ) $(ASAN_DIR)/libwpd.a
	$(CC) $(LDFLAGS) $(ASAN_SAN) -o $@ $^ $(LDLIBS)

asan-build: deps
	@$(MAKE) --no-print-directory -j$(JOBS) $(ASAN_DIR)/wpd $(ASAN_DIR)/unit_tests

test-asan: asan-build
	tests/asan.sh $(ASAN_DIR)

-include $(FUZZ_LIB_OBJ:.o=.d) $(FUZZ_CODEC_OBJ:.o=.d) $(ASAN_LIB_OBJ:.o=.d) $(ASAN_MAIN_OBJ:.o=.d) $(ASAN_TEST_OBJ:.o=.d)

# ---- Coverage of the test tiers (docs/testing.md) ----------------------------
# make coverage [TIER=fast|full]  line coverage of src/ and tools/ by one tier,
#                                 a gcov build in build/cov (wpd, wpd-mpi, unit
#                                 tests), summary in build/cov/TIER.json;
#                                 tests/coverage_compare.py compares two tiers.
COV_DIR      := build/cov
COV_FLAGS    := -O1 --coverage
COV_LIB_OBJ  := $(LIB_SRC:%.c=$(COV_DIR)/%.o)
COV_MAIN_OBJ := $(COV_DIR)/src/cli/main.o
COV_TEST_OBJ := $(TEST_SRC:%.c=$(COV_DIR)/%.o)
TIER         ?= fast

.PHONY: coverage coverage-build

$(COV_DIR)/%.o: %.c
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) $(COV_FLAGS) -MMD -MP -c -o $@ $<

$(COV_DIR)/mpi/par_mpi.o: src/par/par_mpi.c
	@mkdir -p $(dir $@)
	$(MPICC) $(CFLAGS) $(COV_FLAGS) -MMD -MP -c -o $@ $<

$(COV_DIR)/libwpd.a: $(COV_LIB_OBJ)
	rm -f $@
	ar rcs $@ $^

$(COV_DIR)/wpd: $(COV_MAIN_OBJ) $(COV_DIR)/libwpd.a
	$(CC) $(LDFLAGS) --coverage -o $@ $^ $(LDLIBS)

$(COV_DIR)/wpd-mpi: $(COV_MAIN_OBJ) $(COV_DIR)/mpi/par_mpi.o $(COV_DIR)/libwpd.a
	$(MPICC) $(LDFLAGS) --coverage -o $@ $^ $(LDLIBS)

$(COV_DIR)/unit_tests: $(COV_TEST_OBJ) $(COV_DIR)/libwpd.a
	$(CC) $(LDFLAGS) --coverage -o $@ $^ $(LDLIBS)

coverage-build: deps lazperf laszip
	@$(MAKE) --no-print-directory -j$(JOBS) $(COV_DIR)/wpd $(COV_DIR)/unit_tests \
	    $(if $(shell command -v $(MPICC)),$(COV_DIR)/wpd-mpi)

coverage: coverage-build
	find $(COV_DIR) -name '*.gcda' -delete
	WPD_BIN=$(CURDIR)/$(COV_DIR)/wpd WPD_MPI_BIN=$(CURDIR)/$(COV_DIR)/wpd-mpi \
	    WPD_UNIT_TESTS=$(COV_DIR)/unit_tests tests/run.sh $(TIER) || true
	gcovr -r . --object-directory $(COV_DIR) -f src/ -f tools/ \
	    --json-summary $(COV_DIR)/$(TIER).json --json-summary-pretty --txt $(COV_DIR)/$(TIER).txt -s

-include $(COV_LIB_OBJ:.o=.d) $(COV_MAIN_OBJ:.o=.d) $(COV_TEST_OBJ:.o=.d) $(COV_DIR)/mpi/par_mpi.d
