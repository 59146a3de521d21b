# OpenAIR kit — the two promises: `make serve` and `make test`.
# Everything runs from the project's own virtual environment (.venv), created on demand.

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
HOST   ?= 127.0.0.1
PORT   ?= 10000
PYTEST_ARGS ?=
PYTEST_WORKERS ?= 2

.PHONY: all venv serve test test-python lint typecheck generate check-generated bench fuzz clean deps-browser
.PHONY: demo-worldmodel mutation faults
.PHONY: stress deps-cluster deps

all: test

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

venv: $(STAMP)

## Run the reference whiteboard server on its embedded default configuration.
serve: $(STAMP)
	$(VENV)/bin/openair serve --host $(HOST) --port $(PORT)

## Regenerate the files derived from the spec (error classes, requirements catalogue).
generate: $(STAMP)
	$(PY) tools/gen_errors.py
	$(PY) tools/gen_catalogue.py
	$(PY) tools/gen_frame_vectors.py
	$(PY) tools/gen_message_vectors.py
	$(PY) tools/gen_session_vectors.py

## Fail if a generated file is stale.
check-generated: $(STAMP)
	$(PY) tools/gen_errors.py --check
	$(PY) tools/gen_catalogue.py --check
	$(PY) tools/gen_frame_vectors.py --check
	$(PY) tools/gen_message_vectors.py --check
	$(PY) tools/gen_session_vectors.py --check

lint: $(STAMP)
	$(VENV)/bin/ruff check reference apps conformance tests tools bench examples
	$(VENV)/bin/ruff format --check reference apps conformance tests tools bench examples

typecheck: $(STAMP)
	$(VENV)/bin/mypy
	MYPYPATH=reference:apps:conformance:examples/worldmodel $(VENV)/bin/mypy --strict examples/worldmodel
	MYPYPATH=reference:apps:conformance:examples/skundar/python $(VENV)/bin/mypy --strict examples/skundar/python

## Debian packages, each as WHAT:PACKAGE where WHAT (a header file, or a command) shows it is
## installed. $(call deb_install,NEEDS) installs the missing ones with one apt-get update.
DEB_CPP     := /usr/include/gtest/gtest.h:libgtest-dev /usr/include/nlohmann/json.hpp:nlohmann-json3-dev \
	/usr/include/CLI/CLI.hpp:libcli11-dev /usr/include/openssl/ssl.h:libssl-dev
DEB_BROWSER := chromium:chromium chromedriver:chromium-driver dot:graphviz
DEB_CLUSTER := nats-server:nats-server
deb_install = missing=""; for need in $(1); do what=$${need%%:*}; pkg=$${need\#*:}; \
	case $$what in /*) [ -f "$$what" ] ;; *) command -v "$$what" >/dev/null ;; esac \
	|| missing="$$missing $$pkg"; done; \
	if [ -n "$$missing" ]; then $(CPP_SUDO) apt-get update && $(CPP_SUDO) apt-get install -y $$missing; fi

## Install headless Chromium, its driver and Graphviz when missing (browser tests, diagrams).
deps-browser:
	@$(call deb_install,$(DEB_BROWSER))

## The cluster tests (issue 22) run nats-server in network namespaces: Debian's package.
deps-cluster:
	@$(call deb_install,$(DEB_CLUSTER))

test-python: $(STAMP) deps-browser deps-cluster datapath-native
	OPENAIR_REQUIRE_BINDINGS=1 OPENAIR_REQUIRE_BROWSER=1 OPENAIR_REQUIRE_CLUSTER=1 $(VENV)/bin/pytest -m "not fuzz" \
		-n $(PYTEST_WORKERS) --dist loadfile $(PYTEST_ARGS)

## Build the server data path's C extension in place (issue #20): the editable venv imports it
## from the tree. Without a compiler the pure-Python data path is used (and tested) instead.
datapath-native: $(STAMP)
	@cc -O2 -shared -fPIC -I"$$($(PY) -c 'import sysconfig; print(sysconfig.get_paths()["include"])')" \
		reference/openair/server/aio/datapath/_native.c \
		-o reference/openair/server/aio/datapath/_native$$($(PY) -c 'import sysconfig; print(sysconfig.get_config_var("EXT_SUFFIX"))') \
		|| echo "datapath-native: no compiler; the pure-Python data path only"

## Every Debian package `make test` needs (deps-cpp, deps-browser, deps-cluster together), the
## missing ones installed with one apt-get update.
deps:
	@$(call deb_install,$(DEB_CPP) $(DEB_BROWSER) $(DEB_CLUSTER))

## Install what is needed and pass every test (pytest on two workers: pytest-xdist, one test
## file per worker at a time, since some files' tests build on each other in order).
test: deps check-generated lint typecheck test-cpp test-java test-python

## The world-model demo (docs/worldmodel.md): exits 0 when the plan fired and terminated.
demo-worldmodel: $(STAMP)
	$(PY) examples/worldmodel/run_demo.py --bound 60

## Skundar, the seed paper's robot (examples/skundar): Figure 1, then Figure 2, compared.
## Builds its C++ modules and installs the Java client offline first. SKUNDAR_ARGS="--load 2".
.PHONY: demo-skundar
demo-skundar: $(STAMP) deps-cpp
	cd bindings/java && mvn -o -q install -DskipTests
	$(PY) examples/skundar/python/run_demo.py --build $(SKUNDAR_ARGS)

## Benchmarks (never part of `make test`).
bench: $(STAMP)
	$(PY) -m bench

## Mutation testing of the reference server, judged by the conformance suite (issue 15). Never
## part of `make test`. By default the campaign of the committed report: a seeded sample of 60
## mutants per module (about an hour on 2 cores); resumable (run it again to continue; sessions
## and the coverage map live in build/mutation). Writes test-artifacts/mutation.md.
## E.g. make mutation MUTATION_ARGS="--modules whiteboard queues --max-mutants 100"
## or every mutant (many hours): MUTATION_ARGS="--workers 2".
MUTATION_ARGS ?= --sample 60 --seed 15 --workers 2 --timeout 120 --timeout-scale 2
mutation: $(STAMP)
	@$(PY) -c "import cosmic_ray, coverage" 2>/dev/null || $(PY) -m pip install --quiet -e '.[mutation]'
	$(PY) -m tools.mutation $(MUTATION_ARGS)

## The hand-written one-fault variants of tests/faults/independent.toml, each judged like a
## mutant (issue 15); writes test-artifacts/independent-faults.md. About 10 minutes.
faults: $(STAMP)
	@$(PY) -c "import cosmic_ray, coverage" 2>/dev/null || $(PY) -m pip install --quiet -e '.[mutation]'
	$(PY) -m tools.mutation.faults

## The attacks of issue #19 against a fresh server: held/degraded/broken, RSS, canary p99 (never
## part of `make test`; about two minutes).
stress: $(STAMP)
	$(PY) -m bench.stress

## Long fuzzing runs (never part of `make test`).
fuzz: $(STAMP)
	HYPOTHESIS_PROFILE=soak $(VENV)/bin/pytest tests -m fuzz -p no:cacheprovider

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .mypy_cache .ruff_cache .hypothesis

# -- C++ binding (bindings/cpp) -----------------------------------------------------------------
CPP_DIR  := bindings/cpp
CPP_JOBS ?= $(shell nproc 2>/dev/null || echo 2)
CPP_SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: deps-cpp cpp test-cpp

## Install what the C++ build needs when missing (Debian): GoogleTest for test-cpp, and the
## header-only nlohmann/json (shim, tests) and CLI11 (examples, tools).
deps-cpp:
	@$(call deb_install,$(DEB_CPP))

## Configure and build the C++ client, examples, shim and broken shim (Release) into
## bindings/cpp/build: what the Python tests drive. CPP_TESTS=ON builds the GoogleTest tests too.
CPP_TESTS ?= OFF
cpp: deps-cpp
	cmake -S $(CPP_DIR) -B $(CPP_DIR)/build -DCMAKE_BUILD_TYPE=Release \
		-DOPENAIR_BUILD_TESTS=$(CPP_TESTS) -DOPENAIR_BUILD_BROKEN_SHIM=ON
	cmake --build $(CPP_DIR)/build --parallel $(CPP_JOBS)

## Build the Release tree, then build and run the C++ tests under ASan/UBSan in
## bindings/cpp/build-asan (every GoogleTest test, once, sanitized: compiling the tests a second
## time for a Release run cost a minute of `make test`; `make cpp CPP_TESTS=ON` still builds them).
test-cpp: deps-cpp
	$(MAKE) --no-print-directory cpp
	cmake -S $(CPP_DIR) -B $(CPP_DIR)/build-asan -DCMAKE_BUILD_TYPE=Debug -DOPENAIR_SANITIZE=ON \
		-DOPENAIR_BUILD_EXAMPLES=OFF -DOPENAIR_BUILD_SHIM=OFF
	cmake --build $(CPP_DIR)/build-asan --parallel $(CPP_JOBS)
	ctest --test-dir $(CPP_DIR)/build-asan --output-on-failure --parallel $(CPP_JOBS)

# -- Java binding (bindings/java) ---------------------------------------------------------------
# Maven runs offline (-o): every plugin and junit-jupiter come from the local repository.
JAVA_DIR := bindings/java

.PHONY: java test-java

## Build the Java client and its shim jar (bindings/java/target/openair.jar, openair-shim.jar).
java:
	cd $(JAVA_DIR) && mvn -o -q package -DskipTests

## Build the Java client and run its JUnit tests (every shared vector, a scripted fake server).
test-java:
	cd $(JAVA_DIR) && mvn -o -q package

# -- Side-by-side benchmark against mosquitto, NATS, Redis and amqtt (bench/peers) ---------------
.PHONY: bench-peers

## Install the peers when missing (Debian: mosquitto, nats-server, redis-server; PyPI: amqtt,
## matplotlib, py-spy into the venv), run every workload on each, write bench/results/.
## BENCH_PEERS_QUICK=1 makes a short smoke run.
bench-peers: $(STAMP)
	@if ! PATH="$$PATH:/usr/sbin:/sbin" sh -c \
		'command -v mosquitto && command -v nats-server && command -v redis-server' >/dev/null; then \
		$(CPP_SUDO) apt-get update && $(CPP_SUDO) apt-get install -y mosquitto nats-server redis-server; \
	fi
	@$(PY) -c "import amqtt, matplotlib" 2>/dev/null && [ -x $(VENV)/bin/py-spy ] \
		|| $(PY) -m pip install --quiet 'amqtt==0.12.1' 'matplotlib>=3.8' 'py-spy>=0.3.14'
	$(PY) -m bench.peers
