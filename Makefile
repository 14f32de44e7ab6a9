# strahl: `make demo` renders every scene in scenes/ to out/, `make test` runs the tests.
# Both install the system packages they need (Debian/Ubuntu) when they are missing.

SHELL := bash
CARGO ?= cargo
# Embree and libclang (for bindgen), and the C toolchain Rust links with.
PACKAGES := libembree-dev libclang-dev gcc libc6-dev
SCENES := $(wildcard scenes/*.toml)
STRAHL := $(or $(CARGO_TARGET_DIR),target)/release/strahl

.PHONY: all deps build demo test test-embree4 bench clean

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

build: deps
	$(CARGO) build --release --locked

demo: build
	@mkdir -p out
	@for s in $(SCENES); do \
	  n=$$(basename $$s .toml); \
	  echo "rendering $$s -> out/$$n.exr, out/$$n.png"; \
	  $(STRAHL) render $$s -o out/$$n.exr --png out/$$n.png || exit 1; \
	done

test: deps
	$(CARGO) test --locked

# The whole suite again against Embree 4 (Debian trixie's 4.3) in a cached debootstrap root
# under /var/cache/strahl (needs root; see tools/test-embree4.sh).
test-embree4:
	bash tools/test-embree4.sh

bench: deps
	$(CARGO) bench --locked

clean:
	$(CARGO) clean
	rm -rf out
