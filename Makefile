# Two entry points on a fresh Debian 12 machine: `make demo` and `make test`.
PRESET ?= release
BUILD := build/$(PRESET)
JOBS ?= $(shell nproc)

.PHONY: deps build demo test faults bench bench-dds bench-track bench-track-people bench-track-faces bench-stereo bench-verge bench-latency bench-view fuzz docs asan tsan clean configure install

deps:
	@bash scripts/install-deps.sh

configure: deps
	@cmake --preset $(PRESET) >/dev/null

build: configure
	@cmake --build --preset $(PRESET) -j $(JOBS)

# Only what graphs/demo.xml needs: the command and four plugins, not the tests and benchmarks.
demo: configure
	@cmake --build --preset $(PRESET) -j $(JOBS) --target saccade_demo
	@rm -rf out/demo && mkdir -p out/demo
	$(BUILD)/bin/saccade run graphs/demo.xml --stats
	@echo "demo: wrote $$(ls out/demo | wc -l) PNGs under out/demo/"

test: build
	@bash scripts/install-test-npm.sh $(BUILD)
	ctest --preset $(PRESET) -j $(JOBS) $(CTEST_ARGS)

# The fault suite (docs/reliability.md): either process of graphs/two_pc.xml killed and restarted,
# its DDS link cut for 5 s, CAN packets dropped/duplicated/reordered/corrupted, a drive silent and
# the cameras stopped, FAULT_ROUNDS rounds of each in a row (default 10; make test runs 1 or 2);
# each round's recovery time and losses, and min/median/max, in out/faults.log and printed.
FAULT_ROUNDS ?= 10
faults: configure
	@cmake --build --preset $(PRESET) -j $(JOBS) --target test_faults_loop test_faults_processes
	@mkdir -p out
	@SACCADE_FAULT_ROUNDS=$(FAULT_ROUNDS) ctest --preset $(PRESET) -L faults -V > out/faults.log 2>&1; rc=$$?; \
	  grep -E '\[ fault \]|tests passed|\(Failed\)|\(Timeout\)|Skipped' out/faults.log; exit $$rc

bench: build
	$(BUILD)/bin/saccade_bench --benchmark_min_time=0.5 --benchmark_repetitions=5 --benchmark_report_aggregates_only=true

bench-dds: build
	$(BUILD)/bin/saccade_dds_bench --messages 2000 --throughput-s 1

# The fovea box tracker against OpenCV's CSRT, KCF and MIL on generated sequences
# (add OTB/VOT folders with TRACK_ARGS="--otb DIR --vot DIR").
bench-track: build
	@mkdir -p out
	$(BUILD)/bin/saccade_track_bench --data /usr/share/doc/opencv-doc/examples/data --markdown out/bench-track.md $(TRACK_ARGS)

# The trackers on 22 pedestrians of opencv-doc's vtest.avi (boxes from OpenCV's HOG people
# detector), 150 frames each, without truth: witness measures (docs/tracking.md).
VTEST := /usr/share/doc/opencv-doc/examples/data/vtest.avi
PEOPLE := 0:249,202,36,116 60:504,195,32,104 60:467,194,35,111 60:614,227,38,123 180:591,206,34,108 \
  180:503,212,34,108 240:629,122,85,272 240:448,246,36,115 240:666,268,38,120 300:309,168,42,136 \
  360:430,234,34,109 360:701,231,35,112 420:292,189,34,111 480:465,232,35,111 480:577,241,35,111 \
  480:607,269,38,123 540:434,160,36,114 540:607,170,33,106 540:640,274,38,122 600:564,191,36,114 \
  600:671,197,34,111 600:636,299,36,116
bench-track-people: build
	@mkdir -p out
	$(BUILD)/bin/saccade_track_bench --no-generated --trackers fovea,csrt --markdown out/bench-track-people.md \
	  $(foreach p,$(PEOPLE),--video $(VTEST):$(p):150) $(TRACK_ARGS)

# The trackers on the four shots of opencv-doc's Megamind.avi (an animated film's faces), each
# from the box OpenCV's Haar face detector gives on its first frame, to the next cut: without
# truth, witness measures (docs/tracking.md).
MEGAMIND := /usr/share/doc/opencv-doc/examples/data/Megamind.avi
FACES := 2:210,165,155,155:96 98:389,112,170,170:56 156:203,149,186,186:44 200:215,62,349,349:70
bench-track-faces: build
	@mkdir -p out
	$(BUILD)/bin/saccade_track_bench --no-generated --trackers fovea,csrt,kcf,mil --markdown out/bench-track-faces.md \
	  $(foreach f,$(FACES),--video $(MEGAMIND):$(f)) $(TRACK_ARGS)

# The retina stereo matcher against OpenCV's StereoBM and StereoSGBM, one thread, on
# Aloe, rendered scenes with exact disparity and opencv-doc's chessboard pairs from a real rig
# (add STEREO_ARGS="--variants" for more).
bench-stereo: build
	@mkdir -p out
	$(BUILD)/bin/saccade_stereo_bench --data /usr/share/doc/opencv-doc/examples/data --markdown out/bench-stereo.md $(STEREO_ARGS)

# The verging head's stereo on capture.sim_head: rectified against plain retinas,
# and against parallel cameras (fixation depth error, fovea correspondence).
bench-verge: build
	@mkdir -p out
	$(BUILD)/bin/saccade_verge_bench --data /usr/share/doc/opencv-doc/examples/data --markdown out/bench-verge.md

# Capture -> CAN joint command of the head loop, in one process and across two
# (LATENCY_S seconds each, default 30); figures in out/bench-latency/figures.md.
bench-latency: build
	SACCADE_BIN=$(BUILD)/bin sh scripts/bench-latency.sh $(or $(LATENCY_S),30) out/bench-latency

# What the live view costs the demo: no server, a server nobody watches, the page's viewer
# and one on every picture channel, in turns (VIEW_ARGS="--rounds 9 --frames 8000" for more).
bench-view: build
	$(BUILD)/bin/saccade_view_bench --graph graphs/demo.xml $(VIEW_ARGS)

# libFuzzer on the graph loader, the channel (DDS/MCAP) decoders, the CAN tunnel
# and CiA 402 frames, image-sequence patterns, the command line, MCAP files and
# the live view's client messages: a clang build with ASan and UBSan under
# build/fuzz, FUZZ_SECONDS each (default 60; CI runs them briefly).
FUZZ_SECONDS ?= 60
fuzz: deps
	@cmake -S . -B build/fuzz -G Ninja -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
	  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSACCADE_FUZZ=ON -DSACCADE_BUILD_TESTS=OFF -DSACCADE_BUILD_BENCHMARKS=OFF >/dev/null
	@cmake --build build/fuzz -j $(JOBS) --target saccade_fuzzers
	FUZZ_FLAGS="$(FUZZ_FLAGS)" sh scripts/fuzz.sh build/fuzz $(FUZZ_SECONDS)

# The SDK into PREFIX: the command, libsaccade, its headers and plugins, find_package(saccade)
# and saccade_add_plugin() (docs/guide.md, "Plugins outside the saccade tree").
PREFIX ?= /usr/local
install: configure
	@cmake --build --preset $(PRESET) -j $(JOBS) --target saccade_sdk
	cmake --install $(BUILD) --prefix $(PREFIX)

docs: build
	$(BUILD)/bin/saccade plugins --markdown > docs/plugins.md

asan:
	@$(MAKE) test PRESET=asan
tsan:
	@$(MAKE) test PRESET=tsan

clean:
	rm -rf build out
