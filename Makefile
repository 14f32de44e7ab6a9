# strahl: `make demo` installs strahl (make install) and renders every scene in scenes/ to out/,
# `make test` runs the tests.
# Both install the system packages they need (Debian/Ubuntu) when they are missing.

SHELL := bash
CARGO ?= cargo
# Embree and libclang (for bindgen), and the C toolchain Rust links with.
PACKAGES := libembree-dev libclang-dev gcc libc6-dev
SCENES := $(wildcard scenes/*.toml)
STRAHL := $(or $(CARGO_TARGET_DIR),target)/release/strahl
# What a target that runs $(STRAHL) needs first: the release build, or only the system packages
# when `STRAHL=path/to/strahl` is given on the command line (install, test-slurm, test-install).
STRAHL_BUILT := $(if $(filter command line,$(origin STRAHL)),deps,build)

# Where `make install` puts bin/strahl: cargo's own bin directory when there is one (rustup puts
# it on PATH), else /usr/local. `make install PREFIX=/opt/strahl` for a farm's shared path.
PREFIX ?= $(if $(wildcard $(HOME)/.cargo/bin),$(HOME)/.cargo,/usr/local)

.PHONY: all deps test-deps oidn build install demo blender-addon test test-cycles test-embree4 test-gltf-blender test-mitsuba test-embree-pathtracer test-slurm test-install forest scale fuzz bench bench-cycles bench-mitsuba bench-pathtracer albedo-tables clean

all: build

# Install the Debian packages strahl builds against, if any is missing; Rust itself comes
# from rustup (Debian bookworm's cargo is older than the 1.86 strahl needs).
deps:
	@command -v $(CARGO) >/dev/null || { echo "strahl needs Rust 1.86 or newer: install it with rustup (https://rustup.rs)" >&2; exit 1; }
	@missing=""; \
	for p in $(PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  command -v apt-get >/dev/null || { echo "strahl needs:$$missing (Embree 3 or 4 and libclang); install them, or set EMBREE_INCLUDE_DIR/EMBREE_LIB_DIR" >&2; exit 1; }; \
	  sudo=""; [ "$$(id -u)" -eq 0 ] || sudo=sudo; \
	  echo "installing:$$missing"; \
	  $$sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq && \
	  $$sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $$missing >/dev/null; \
	fi

# Intel Open Image Denoise 2.5.1 (Apache-2.0), for `--denoise` and `strahl denoise`. Debian 12
# has no package of it: `make oidn` fetches the PyPI wheel pyoidn 2.5.1.0 (the wheel's Python
# code is MIT; it ships OIDN's official Linux libraries) with `pip download` (nothing is
# installed), and unpacks only OIDN's CPU libraries and TBB (Apache-2.0) into $(OIDN_DIR)/lib
# (≈ 65 MB), writing nothing else. With that folder present, the cargo commands of this
# Makefile build strahl with the `denoise` feature against it (the binary finds the libraries
# by its rpath; src/denoise.rs); without it strahl builds and runs without denoising.
OIDN_VERSION := 2.5.1
OIDN_WHEEL := pyoidn==2.5.1.0
OIDN_DIR ?= $(or $(XDG_CACHE_HOME),$(HOME)/.cache)/strahl/oidn-$(OIDN_VERSION)
OIDN_LIB := $(OIDN_DIR)/lib/libOpenImageDenoise.so.$(OIDN_VERSION)
# A shell test, not $(wildcard): make caches directories, and `make oidn` may have just made it.
DENOISE_FEATURE = $$(test -f '$(OIDN_LIB)' && echo --features denoise)
export OIDN_DIR
oidn:
	@if [ -f "$(OIDN_LIB)" ]; then exit 0; fi; \
	set -e; tmp=$$(mktemp -d); trap 'rm -rf "$$tmp"' EXIT; \
	echo "fetching OIDN $(OIDN_VERSION) (the PyPI wheel $(OIDN_WHEEL), 88 MB) into $(OIDN_DIR)"; \
	python3 -m pip download -q --disable-pip-version-check --no-deps --only-binary :all: \
	  --platform manylinux2014_x86_64 $(OIDN_WHEEL) -d "$$tmp" || \
	  { echo "make oidn: pip could not download $(OIDN_WHEEL); --denoise stays unavailable" >&2; exit 1; }; \
	mkdir -p "$$tmp/oidn/lib"; \
	python3 -c 'import sys, zipfile, os; z = zipfile.ZipFile(sys.argv[1]); d = sys.argv[2]; \
	keep = [n for n in z.namelist() if n.startswith("pyoidn/oidn/lib/lib") and \
	  os.path.basename(n).split(".so")[0] in ("libOpenImageDenoise", "libOpenImageDenoise_core", "libOpenImageDenoise_device_cpu", "libtbb")]; \
	assert any(n.endswith("libOpenImageDenoise.so.$(OIDN_VERSION)") for n in keep), "no libOpenImageDenoise.so.$(OIDN_VERSION) in the wheel"; \
	[open(os.path.join(d, "lib", os.path.basename(n)), "wb").write(z.read(n)) for n in keep]' \
	  "$$(ls "$$tmp"/pyoidn-*.whl)" "$$tmp/oidn"; \
	mkdir -p "$$(dirname "$(OIDN_DIR)")"; rm -rf "$(OIDN_DIR)"; mv "$$tmp/oidn" "$(OIDN_DIR)"; \
	echo "OIDN $(OIDN_VERSION) in $(OIDN_DIR)/lib"

build: deps
	$(CARGO) build --release --locked $(DENOISE_FEATURE)

# The release binary, on PATH, so that the README's `strahl …` commands work as written; with
# OIDN, its libraries in a `lib` folder of their own, which is where they look for each other
# (their run path is `$ORIGIN/../lib`; build.rs).
# `make install STRAHL=path/to/strahl` installs that binary instead of building the release one.
install: $(STRAHL_BUILT)
	install -d "$(PREFIX)/bin"
	install -m 755 $(STRAHL) "$(PREFIX)/bin/strahl"
	@if [ -f "$(OIDN_LIB)" ]; then install -d "$(PREFIX)/lib/strahl/oidn/lib" && cp -P "$(OIDN_DIR)"/lib/lib*.so* "$(PREFIX)/lib/strahl/oidn/lib/" && \
	  echo "installed OIDN's libraries in $(PREFIX)/lib/strahl/oidn/lib"; fi
	@# Copies that make install put in PREFIX/lib/strahl itself before the oidn/lib folder (strahl no longer looks there).
	@if [ -d "$(PREFIX)/lib/strahl" ]; then find "$(PREFIX)/lib/strahl" -maxdepth 1 ! -type d \
	  \( -name 'libOpenImageDenoise*.so*' -o -name 'libtbb*.so*' \) -print -delete | sed 's/^/removed an earlier install'"'"'s /'; fi
	@echo "installed $(PREFIX)/bin/strahl"

demo: install
	@mkdir -p out
	@for s in $(SCENES); do \
	  n=$$(basename $$s .toml); \
	  echo "rendering $$s -> out/$$n.exr, out/$$n.png"; \
	  $(STRAHL) render $$s -o out/$$n.exr --png out/$$n.png || exit 1; \
	done

# The Blender add-on (blender/strahl_engine: the render engine "strahl") as out/strahl_engine.zip,
# for Edit > Preferences > Add-ons > Install (README, "Rendering from Blender"). Python's own
# zipfile, so no zip tool is needed; __pycache__ is left out.
blender-addon:
	@mkdir -p out
	@python3 -c 'import pathlib, sys, zipfile; src = pathlib.Path("blender/strahl_engine"); \
	  files = sorted(p for p in src.rglob("*.py") if "__pycache__" not in p.parts); \
	  z = zipfile.ZipFile("out/strahl_engine.zip", "w", zipfile.ZIP_DEFLATED); \
	  [z.write(p, p.relative_to(src.parent)) for p in files]; z.close(); \
	  print("wrote out/strahl_engine.zip:", ", ".join(str(p.relative_to(src.parent)) for p in files))'

# Readers strahl did not write, which tests use to check its files (they skip, saying so, when a
# tool is missing): exrheader (openexr), oiiotool (openimageio-tools), Python's OpenEXR, mmh3 and
# numpy; pygltflib and trimesh (glTF files written by another library; make forest); Mitsuba 3;
# Embree's tutorial path tracer `pathtracer` (embree-tools, tests/embree_pathtracer.rs).
TEST_PACKAGES := openexr openimageio-tools embree-tools
PIP_TEST_MODULES := OpenEXR mmh3 numpy pygltflib trimesh
test-deps:
	@missing=""; \
	for p in $(TEST_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ] && command -v apt-get >/dev/null; then \
	  sudo=""; [ "$$(id -u)" -eq 0 ] || sudo=sudo; \
	  echo "installing for the tests:$$missing"; \
	  $$sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $$missing >/dev/null || \
	  echo "note: could not install$$missing; the tests that need them will say they skip"; \
	fi
	@$(call pip_install,$(PIP_TEST_MODULES),import OpenEXR; import mmh3; import numpy; import pygltflib; import trimesh)
	@python3 -c "import mitsuba" 2>/dev/null || \
	  python3 -m pip install -q --disable-pip-version-check mitsuba 2>/dev/null || \
	  python3 -m pip install -q --disable-pip-version-check --break-system-packages mitsuba 2>/dev/null || \
	  echo "note: could not pip-install mitsuba; tests/mitsuba.rs will say it skips (make test-mitsuba makes it a failure)"

# $(call pip_install,PACKAGES,IMPORTS): pip-installs PACKAGES unless python3 can run IMPORTS
# (a Debian python3 refuses a plain `pip install` outside a venv, hence the second try).
pip_install = python3 -c "$(2)" 2>/dev/null || \
  python3 -m pip install -q --disable-pip-version-check $(1) 2>/dev/null || \
  python3 -m pip install -q --disable-pip-version-check --break-system-packages $(1) 2>/dev/null || \
  echo "note: could not pip-install $(1); what needs them will say it skips"

# Every test that skips a check for want of a tool appends `SKIPPED: TEST: WHY` to SKIP_LOG
# (tests/common/mod.rs, `skip`); the lines are listed after the suite, whatever its outcome.
SKIP_LOG := $(abspath $(or $(CARGO_TARGET_DIR),target))/skipped-tests.txt
test: deps test-deps
	@$(MAKE) --no-print-directory oidn || echo "note: OIDN could not be fetched; the denoising tests will say they skip"
	@mkdir -p $(dir $(SKIP_LOG)) && rm -f $(SKIP_LOG)
	@status=0; STRAHL_SKIP_LOG=$(SKIP_LOG) $(CARGO) test --locked --no-fail-fast $(DENOISE_FEATURE) || status=$$?; \
	if [ -s $(SKIP_LOG) ]; then \
	  echo "skipped checks: $$(sort -u $(SKIP_LOG) | wc -l) (install the tool each names to run it):"; sort -u $(SKIP_LOG); \
	else echo "no test skipped a check"; fi; \
	exit $$status

# The whole suite again against Embree 4 (Debian trixie's 4.3) in a cached debootstrap root
# under /var/cache/strahl (needs root; see tools/test-embree4.sh).
test-embree4:
	bash tools/test-embree4.sh

# strahl against Mitsuba 3 (pip's `mitsuba`, installed for the user when python3 cannot import
# it): the Cornell box lit by its area light, rendered by both and compared pixel by pixel within
# their noise (tools/mitsuba-compare.py, tests/mitsuba.rs, docs/mitsuba.md). `make test` installs
# Mitsuba too when pip can (a 68 MB download, ~4 s to install) and runs the test, which skips
# loudly only when Mitsuba still cannot be imported; here a missing Mitsuba is a failure.
test-mitsuba: deps
	@python3 -c "import mitsuba, numpy, tomllib" 2>/dev/null || \
	  python3 -m pip install -q --disable-pip-version-check --user mitsuba numpy 2>/dev/null || \
	  python3 -m pip install -q --disable-pip-version-check --user --break-system-packages mitsuba numpy 2>/dev/null || \
	  python3 -m pip install -q --disable-pip-version-check mitsuba numpy
	STRAHL_REQUIRE_MITSUBA=1 $(CARGO) test --locked $(DENOISE_FEATURE) --test mitsuba -- --nocapture

# The path tracer against Embree's own tutorial path tracer (`pathtracer` of Debian's
# embree-tools, 11 MB) on the Cornell box OBJ of the test meshes (tests/embree_pathtracer.rs,
# docs/embree-pathtracer.md). `make test` installs embree-tools too and the test skips loudly
# without it; here a missing `pathtracer` is a failure.
test-embree-pathtracer: deps
	@command -v pathtracer >/dev/null || { \
	  sudo=""; [ "$$(id -u)" -eq 0 ] || sudo=sudo; \
	  echo "installing: embree-tools"; \
	  $$sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends embree-tools >/dev/null; }
	STRAHL_REQUIRE_EMBREE_PATHTRACER=1 $(CARGO) test --locked $(DENOISE_FEATURE) --test embree_pathtracer -- --nocapture

# A real one-node Slurm cluster on localhost (installs Debian's Slurm and munge when missing;
# needs root): an 8-tile `strahl farm slurm` render merged equals a single-process render.
# `make test-slurm STRAHL=path/to/strahl` runs that binary instead of building the release one
# (CI passes the one `make test` has just built, which saves a 2-minute release build).
test-slurm: $(STRAHL_BUILT)
	STRAHL=$(abspath $(STRAHL)) bash tools/test-slurm.sh

# make install's layout, in a scratch PREFIX: the installed strahl renders, and where OIDN is
# there it loads OIDN's libraries from where make install put them (not from the cache folder)
# and denoises; OIDN copies of the older layout (in lib/strahl itself) are removed, nothing
# else. `make test-install STRAHL=path/to/strahl` as for test-slurm.
test-install: $(STRAHL_BUILT)
	@tmp=$$(mktemp -d); trap 'rm -rf "$$tmp"' EXIT; \
	mkdir -p "$$tmp/lib/strahl" && touch "$$tmp/lib/strahl/libOpenImageDenoise.so.2" "$$tmp/lib/strahl/keep"; \
	$(MAKE) --no-print-directory install PREFIX="$$tmp" STRAHL="$(abspath $(STRAHL))" >/dev/null || exit 1; \
	[ ! -e "$$tmp/lib/strahl/libOpenImageDenoise.so.2" ] && [ -e "$$tmp/lib/strahl/keep" ] || \
	  { echo "test-install: make install did not remove exactly the old layout's OIDN copy from $$tmp/lib/strahl" >&2; exit 1; }; \
	args="scenes/cornell.toml --width 16 --height 12 --spp 2 --integrator path"; \
	passed="passed; SKIPPED the denoiser: no OIDN in $(OIDN_DIR) (make oidn)"; \
	if [ -f "$(OIDN_LIB)" ]; then \
	  ldd "$$tmp/bin/strahl" | grep libOpenImageDenoise_core | grep -q "=> $$tmp/" || \
	    { echo "test-install: the installed strahl does not load OIDN from $$tmp/lib/strahl/oidn/lib:" >&2; ldd "$$tmp/bin/strahl" >&2; exit 1; }; \
	  args="$$args --denoise"; passed="passed (strahl and OIDN from PREFIX)"; \
	fi; \
	"$$tmp/bin/strahl" render $$args -o "$$tmp/t.exr" >"$$tmp/log" 2>&1 || { cat "$$tmp/log" >&2; exit 1; }; \
	echo "test-install: $$passed"

# glTF files from tools strahl did not write: Blender's own exporter (needs `blender`; its
# exporter needs numpy) and pygltflib (pip), compared with the same scenes built by hand
# (tests/gltf_external.rs; `make test` runs them too, skipping loudly without the tools).
test-gltf-blender: deps
	@command -v blender >/dev/null || { echo "test-gltf-blender needs Blender: apt-get install blender python3-numpy" >&2; exit 1; }
	$(CARGO) test --locked $(DENOISE_FEATURE) --test gltf_external -- --nocapture

# The path tracer against Blender Cycles on the same glTF file (tests/cycles.rs: a Cornell-like
# room built and exported by Blender, rendered by both, compared within noise; no pixel black
# with either backend), then the glTF import checks against Blender's exporter, the Blender
# add-on rendering through strahl (tests/blender_engine.rs) and Khronos sample models against
# Cycles (tests/khronos_models.rs). Installs
# Debian's blender, the numpy its glTF exporter needs and xvfb (F12 in Blender's window, about
# 7 s) when missing (about 45 s, needs root).
test-cycles: deps
	@command -v blender >/dev/null && command -v xvfb-run >/dev/null && command -v xauth >/dev/null && dpkg-query -W -f='$${Status}' python3-numpy 2>/dev/null | grep -q "install ok installed" || { \
	  sudo=""; [ "$$(id -u)" -eq 0 ] || sudo=sudo; \
	  echo "installing: blender python3-numpy xvfb xauth"; \
	  $$sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq && \
	  $$sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends blender python3-numpy xvfb xauth >/dev/null; }
	STRAHL_REQUIRE_BLENDER=1 $(CARGO) test --locked $(DENOISE_FEATURE) --test cycles --test gltf_external --test blender_engine --test khronos_models -- --nocapture

# Instancing at scale: 1000 instances of a 327,680-triangle icosphere (327.7 M triangles as
# rays see them), generated by tools/gltf/forest.py (python3 with numpy, trimesh and pygltflib,
# pip-installed when missing), rendered at 1920x1080 with its peak memory (measured: 172 MB vs 154 MB for one
# copy).
forest: build
	@mkdir -p out
	@$(call pip_install,numpy trimesh pygltflib,import numpy; import trimesh; import pygltflib)
	@python3 -c "import numpy, trimesh, pygltflib" 2>/dev/null || { echo "make forest needs python3 with numpy, trimesh and pygltflib (pip install numpy trimesh pygltflib)" >&2; exit 1; }
	python3 tools/gltf/forest.py 1000 $(or $(CARGO_TARGET_DIR),target)/forest.glb
	$(STRAHL) info $(or $(CARGO_TARGET_DIR),target)/forest.glb
	/usr/bin/time -v $(STRAHL) render $(or $(CARGO_TARGET_DIR),target)/forest.glb --width 1920 --height 1080 -o out/forest.exr --png out/forest.png 2>&1 | grep -E 'backend|rays|time:|wrote|Maximum resident'

# The shipped scale scene (scenes/scale/forest.toml, written by tools/scale/forest_toml.py):
# 1,000 placements of blob.ply refined to 327,680 triangles (327.7 M triangles as rays see
# them), and the one-blob baseline (scenes/scale/one.toml), each at 1920x1080 on both backends
# with its render time and peak memory (measured: 172/164 MB vs 159/147 MB for one blob).
scale: build
	@mkdir -p out
	@for s in one forest; do for b in embree native; do \
	  echo "scenes/scale/$$s.toml ($$b) -> out/scale-$$s-$$b.exr, .png"; \
	  /usr/bin/time -v $(STRAHL) render scenes/scale/$$s.toml --backend $$b -o out/scale-$$s-$$b.exr \
	    --png out/scale-$$s-$$b.png 2>&1 | grep -E 'time:|Maximum resident|error' || exit 1; \
	done; done

# Fuzz the readers with cargo-fuzz (nightly Rust; installs cargo-fuzz if missing): each target
# of fuzz/ runs FUZZ_SECONDS (default 600) with a 10 s hang timeout and a 2 GB memory limit,
# seeded with the shipped scenes, the test data's OBJ/MTL/PLY files (../shared/data/meshes, or
# STRAHL_TEST_DATA), a pygltflib-written glTF, the PNGs of docs/ and, for exr_part (merge parts),
# 8 × 6 tiles rendered by a built strahl in every compression, alone and in pairs (checkpoint
# makes its own valid headers and checksums, see fuzz/fuzz_targets/checkpoint.rs). A crash, hang
# or OOM leaves its input in fuzz/artifacts/TARGET/ and stops with a non-zero status; make it a
# regression test. fuzz/Cargo.lock is committed and must match strahl's dependencies: a stale one
# stops `make fuzz` before anything is built, instead of being rewritten in the work tree (cargo
# fuzz has no --locked of its own).
FUZZ_SECONDS ?= 600
FUZZ_TARGETS ?= scene_toml obj_mtl ply gltf polygon farm_script texture exr_part checkpoint
FUZZ_DATA := $(or $(STRAHL_TEST_DATA),../shared/data)/meshes
fuzz:
	@command -v cargo-fuzz >/dev/null || $(CARGO) install cargo-fuzz --locked
	@(cd fuzz && $(CARGO) +nightly metadata --locked --format-version 1 >/dev/null) || \
	  { echo "fuzz: fuzz/Cargo.lock does not match strahl's dependencies: run 'cargo +nightly update --workspace --manifest-path fuzz/Cargo.toml' and commit it" >&2; exit 1; }
	@mkdir -p $(addprefix fuzz/corpus/,scene_toml obj_mtl ply gltf texture exr_part $(FUZZ_TARGETS))
	@cp scenes/*.toml fuzz/corpus/scene_toml/
	@find docs -size -1000k \( -name '*.png' -o -name '*.jpg' \) -exec cp {} fuzz/corpus/texture/ \;
	@if [ -d "$(FUZZ_DATA)" ]; then \
	  find "$(FUZZ_DATA)" -size -1000k \( -name '*.obj' -o -name '*.mtl' \) | while read -r f; do cp "$$f" "fuzz/corpus/obj_mtl/$$(echo "$$f" | md5sum | cut -c1-16)"; done; \
	  find "$(FUZZ_DATA)" -size -1000k -name '*.ply' | while read -r f; do cp "$$f" "fuzz/corpus/ply/$$(echo "$$f" | md5sum | cut -c1-16)"; done; \
	else echo "fuzz: no test data at $(FUZZ_DATA); obj_mtl and ply start from scratch"; fi
	@python3 tools/gltf/pygltflib_scene.py fuzz/corpus/gltf/seed.gltf 2>/dev/null || echo "fuzz: pygltflib missing (pip install pygltflib); gltf starts from scratch"
	@strahl=$$(for b in $(STRAHL) $(or $(CARGO_TARGET_DIR),target)/debug/strahl; do [ -x "$$b" ] && echo "$$b" && break; done); \
	if [ -n "$$strahl" ]; then \
	  for c in zip zips none rle piz pxr24 b44; do \
	    for t in 1 2; do \
	      SOURCE_DATE_EPOCH=0 $$strahl render scenes/cornell.toml --width 8 --height 6 --spp 1 --passes all --cryptomatte-levels 1 \
	        --compression $$c --tile $$t/2 -o fuzz/corpus/exr_part/$$c-$$t.exr >/dev/null 2>&1 || exit 1; \
	    done; \
	    { cat fuzz/corpus/exr_part/$$c-1.exr; printf '\0strahl\0'; cat fuzz/corpus/exr_part/$$c-2.exr; } > fuzz/corpus/exr_part/$$c-both; \
	  done; \
	else echo "fuzz: no strahl binary (make build); exr_part starts from scratch"; fi
	@for t in $(FUZZ_TARGETS); do \
	  echo "fuzz: $$t for $(FUZZ_SECONDS) s"; \
	  (cd fuzz && set -o pipefail && cargo +nightly fuzz run -O $$t corpus/$$t -- -max_total_time=$(FUZZ_SECONDS) -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 2>&1 | grep -E '^(stat::number_of_executed_units|stat::peak_rss_mb|INFO: Done|==[0-9]+== ERROR|SUMMARY|artifact_prefix|Test unit written)') || exit 1; \
	done

bench: deps
	$(CARGO) bench --locked

# strahl against Blender Cycles (CPU) on the same file: samples per second at 1920x1080 on 1 and
# 2 threads, and the CPU time each takes to the same RMSE, on the Cornell-like room and on the
# textured 1.1M-triangle room (tools/bench/cycles_time.py; the figures and the method are in
# docs/performance.md). About 40 CPU-minutes; not part of `make test`. Skips,
# saying so, without Blender.
bench-cycles:
	@command -v blender >/dev/null || { echo "bench-cycles: skipped: blender is not installed (apt-get install blender python3-numpy)"; exit 0; }; \
	$(MAKE) --no-print-directory build && \
	for s in cornell dense; do python3 tools/bench/cycles_time.py --scene $$s --strahl $(STRAHL) || exit 1; done

# strahl against Mitsuba 3 (scalar_rgb, its independent and low-discrepancy samplers) on the
# Cornell box both render in `make test-mitsuba`: samples per CPU-second on 1 and 2 threads and
# the CPU time to the same RMSE (tools/bench/mitsuba_time.py; figures in docs/performance.md).
# About 8 CPU-minutes; not part of `make test`. Installs Mitsuba with pip when it can.
bench-mitsuba:
	@$(call pip_install,mitsuba numpy OpenEXR,import mitsuba; import numpy; import OpenEXR)
	@python3 -c "import mitsuba, numpy, OpenEXR" 2>/dev/null || { echo "bench-mitsuba: python3 cannot import mitsuba, numpy and OpenEXR (pip install mitsuba numpy OpenEXR)" >&2; exit 1; }
	$(MAKE) --no-print-directory build
	python3 tools/bench/mitsuba_time.py --strahl $(STRAHL)

# strahl against Embree's tutorial `pathtracer` (embree-tools) on the Cornell box OBJ both read
# (tests/embree_pathtracer.rs's scene): samples per CPU-second on 1 and 2 threads and the CPU
# time to the same RMSE (tools/bench/pathtracer_time.py; figures in docs/performance.md). About
# 6 CPU-minutes; not part of `make test`. Its tools (embree-tools, numpy, OpenEXR) are the
# tests' own (test-deps).
bench-pathtracer: deps test-deps
	@command -v pathtracer >/dev/null || { echo "bench-pathtracer: pathtracer is missing (apt-get install embree-tools)" >&2; exit 1; }
	@python3 -c "import numpy, OpenEXR" 2>/dev/null || { echo "bench-pathtracer: python3 cannot import numpy and OpenEXR (pip install numpy OpenEXR)" >&2; exit 1; }
	$(MAKE) --no-print-directory build
	python3 tools/bench/pathtracer_time.py --strahl $(STRAHL)

# Write src/bsdf/albedo_tables.bin again from the quadrature (bsdf::albedo: after a change to a
# microfacet or sheen lobe, or to the quadrature; the test shipped_tables_are_the_quadrature
# fails until then). About 2 s of a release build's time.
albedo-tables: deps
	$(CARGO) test --release --locked --lib -- --ignored write_albedo_tables

clean:
	$(CARGO) clean
	rm -rf out
