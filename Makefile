# Entry points for people and CI. Each target installs what it needs first (idempotent).
#   make demo   - set up, build (release) and run the main job on the built-in demo scene
#   make test   - set up, build and run every test: release preset, then ASan+UBSan preset
#   make bench  - build and run the benchmarks against the reference peers (Open3D)
#   make fuzz   - build the libFuzzer targets (clang, fuzz preset) and run each for FUZZ_SECONDS
#   make fuzz-short - the short pass `make test` includes (FUZZ_SHORT_SECONDS each, via CTest)
JOBS ?= $(shell nproc)
FUZZ_SECONDS ?= 600
FUZZ_SHORT_SECONDS ?= 10
FUZZ_TARGETS = $(patsubst fuzz/%_fuzz.cpp,%,$(wildcard fuzz/*_fuzz.cpp))
DEMO_OUT ?= out/demo

.PHONY: setup build demo test test-release test-asan test-fuzz-short fuzz fuzz-build fuzz-short bench clean

setup:
	@scripts/setup.sh

build: setup
	cmake --preset release
	cmake --build --preset release -j $(JOBS)

demo: build
	scripts/demo.sh build/release/locard $(DEMO_OUT)

test: test-release test-asan test-fuzz-short

test-release: build
	ctest --preset release

# The asan preset builds with -g1 (line tables: enough for the sanitizers' stack traces): with
# full -g its ~80 test executables, each holding the static library, filled CI's disk.
test-asan: setup
	cmake --preset asan
	cmake --build --preset asan -j $(JOBS)
	ctest --preset asan

test-fuzz-short: fuzz-short

# One target after the other, single process each (scripts/fuzz.sh: niced, scratch copy of the
# corpus, a finding left in fuzz/findings/<reader>/ and the run stopped); logs in build/fuzz/logs.
fuzz-build: setup
	cmake --preset fuzz -DLOCARD_FUZZ_SHORT_SECONDS=$(FUZZ_SHORT_SECONDS)
	cmake --build --preset fuzz -j $(JOBS)

fuzz: fuzz-build
	mkdir -p build/fuzz/logs
	@for t in $(FUZZ_TARGETS); do \
	  echo "fuzz: $$t for $(FUZZ_SECONDS) s"; \
	  scripts/fuzz.sh build/fuzz/fuzz/$${t}_fuzz fuzz/corpus/$$t $(FUZZ_SECONDS) build/fuzz/logs/$$t.log \
	    > /dev/null || { echo "fuzz: $$t found a problem, see build/fuzz/logs/$$t.log"; exit 1; }; \
	  tail -n 12 build/fuzz/logs/$$t.log | grep -E '^(stat::|Done)'; \
	done

fuzz-short: fuzz-build
	ctest --preset fuzz

bench: build
	scripts/bench.sh build/release

clean:
	rm -rf build out
