# Entry points for people and CI. Each target installs what it needs first (idempotent).
#   make demo   - set up, build (release) and run the main job on the built-in demo scene
#   make test   - set up, build and run every test: release preset, then ASan+UBSan preset
#   make bench  - build and run the benchmarks against the reference peers (Open3D)
JOBS ?= $(shell nproc)
DEMO_OUT ?= out/demo

.PHONY: setup build demo test test-release test-asan bench clean

setup:
	@scripts/setup.sh

build: setup
	cmake --preset release
	cmake --build --preset release -j $(JOBS)

demo: build
	scripts/demo.sh build/release/locard $(DEMO_OUT)

test: test-release test-asan

test-release: build
	ctest --preset release

test-asan: setup
	cmake --preset asan
	cmake --build --preset asan -j $(JOBS)
	ctest --preset asan

bench: build
	scripts/bench.sh build/release

clean:
	rm -rf build out
