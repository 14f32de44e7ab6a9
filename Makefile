# strahl: `make demo` renders every scene in scenes/ to out/, `make test` runs the tests.
# Both install the system packages they need (Debian/Ubuntu) when they are missing.

SHELL := bash
CARGO ?= cargo
PACKAGES := libembree-dev libclang-dev
SCENES := $(wildcard scenes/*.toml)

.PHONY: all deps build demo test bench clean

all: build

# Install the Debian packages strahl builds against, if any is missing.
deps:
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
	  target/release/strahl render $$s -o out/$$n.exr --png out/$$n.png || exit 1; \
	done

test: deps
	$(CARGO) test --locked

bench: deps
	$(CARGO) bench --locked

clean:
	$(CARGO) clean
	rm -rf out
