# nzlua - analytical mechanics with Taylor jets, in C with Lua 5.4.
#
#   make          build build/nzlua (the program) and build/nz.so (the module)
#   make demo     install the missing Debian packages of DEMO_PKGS, build, run the showcase
#   make test     install TEST_PKGS, build and run every test (also under ASan and UBSan)
#   make kernel   the Jupyter kernel spec for you (KERNEL_PKGS installed first)
#   make sanitize only the tests under AddressSanitizer + UBSan
#   make bench    print the benchmark tables
#   make fuzz     the differential fuzzer: random systems recorded against Lua
#   make install  nzlua to $(PREFIX)/bin, nz.so to $(PREFIX)/lib/lua/5.4 (PREFIX=/usr/local)
#   make clean

PKGS      = lua5.4 gsl readline
# Debian packages, in three sets (tools/deps.sh installs the missing ones as
# root, else prints the apt-get line).  What building and running need
# (`make`, `make demo`): the compiler, Lua, readline, GSL, and gnuplot to
# plot.  What the Jupyter kernel needs (`make kernel`, `make install`;
# docs/kernel.md): ipykernel speaks the protocol, the notebook itself,
# MathJax and three.js served from Debian's copies.  What the tests need
# (`make test`, `check`, `sanitize`, `bench`, `notebook-screenshot`): both
# sets, busted and tmux, python3-numpy (it runs the Python that sys:export
# writes), GNU parallel (sweeps across machines), and nbclient, nbconvert
# and chromium (the kernel run as a notebook, exported, shown in a browser).
DEMO_PKGS   = make gcc pkg-config liblua5.4-dev lua5.4 libreadline-dev libgsl-dev gnuplot-nox
KERNEL_PKGS = python3-ipykernel jupyter-client python3-zmq jupyter-notebook jupyter-nbconvert libjs-mathjax libjs-three
TEST_PKGS   = $(DEMO_PKGS) $(KERNEL_PKGS) lua-busted tmux python3-numpy parallel \
              python3-nbclient python3-nbconvert chromium

CC       ?= cc
WARN      = -Wall -Wextra -Werror -Wshadow -Wstrict-prototypes -Wmissing-prototypes
CFLAGS   ?= -O2 -g
ALL_CFLAGS = -std=c11 -D_GNU_SOURCE -fPIC $(WARN) $(CFLAGS) \
             $(shell pkg-config --cflags $(PKGS) 2>/dev/null) -Isrc -Ibuild/gen
LUA_LIBS  = $(shell pkg-config --libs lua5.4 2>/dev/null)
GSL_LIBS  = $(shell pkg-config --libs gsl 2>/dev/null)
RL_LIBS   = $(shell pkg-config --libs readline 2>/dev/null)
# dlopen for compiled graphs (in libc since glibc 2.34; harmless there).
DL_LIBS   = -ldl
SAN_FLAGS = -O1 -g -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all
# The plain build optimizes across files: a right-hand side crosses the ODE
# layer, the mechanics, the recorded system and its machine code (ode.c ->
# mech.c -> mech_graph.c -> graph_native.c), a few nanoseconds per call each
# that inlining removes (Henon-Heiles, rk8pd: about 10 % of the whole run).
OPT       = -flto=auto -fno-semantic-interposition

# The numerical core (never includes lua.h), one folder per layer, lowest
# first (docs/architecture.md); then the Lua binding; then the program.
# Includes are written from src/: #include "jets/jet.h".
CORE_DIRS = core jets graph mech ode
CORE_SRC  = $(foreach d,$(CORE_DIRS),$(sort $(wildcard src/$(d)/*.c)))
LUA_SRC   = $(sort $(wildcard src/lua/*.c))
APP_SRC   = src/app/nzlua.c src/app/session_call.c src/app/repl_complete.c src/app/kernel_io.c
HDRS      = $(wildcard src/*/*.h)
LUA_MODS  = $(sort $(wildcard lua/nz/*.lua lua/nz/*/*.lua))
# The Jupyter kernel's Python half, carried inside nzlua for --install-kernel.
KERNEL_PY = jupyter/nzlua_kernel.py
GEN_SRC   = build/gen/embedded_lua.c

B         = build
OBJ       = $(patsubst src/%.c,$(B)/obj/%.o,$(CORE_SRC) $(LUA_SRC)) $(B)/obj/embedded_lua.o
SAN_OBJ   = $(patsubst src/%.c,$(B)/asan/%.o,$(CORE_SRC) $(LUA_SRC)) $(B)/asan/embedded_lua.o
CORE_OBJ  = $(patsubst src/%.c,$(B)/obj/%.o,$(CORE_SRC))
SAN_CORE  = $(patsubst src/%.c,$(B)/asan/%.o,$(CORE_SRC))

PREFIX   ?= /usr/local
DESTDIR  ?=

.PHONY: all deps deps-demo deps-kernel demo test check sanitize bench fuzz install uninstall kernel notebook-screenshot clean

all: $(B)/nzlua $(B)/nz.so

deps:
	@tools/deps.sh $(TEST_PKGS)
deps-demo:
	@tools/deps.sh $(DEMO_PKGS)
deps-kernel:
	@tools/deps.sh $(DEMO_PKGS) $(KERNEL_PKGS)

$(GEN_SRC): tools/embed.lua $(LUA_MODS) $(KERNEL_PY) | $(B)/gen
	lua5.4 tools/embed.lua $@ $(LUA_MODS) $(KERNEL_PY)

# Objects mirror the source folders: src/jets/jet.c -> build/obj/jets/jet.o.
$(B)/obj/%.o: src/%.c $(HDRS) | $(B)/obj
	@mkdir -p $(@D)
	$(CC) $(ALL_CFLAGS) $(OPT) -c -o $@ $<
# The generated file includes "embedded.h" (tools/embed.lua), which lives in src/lua.
$(B)/obj/embedded_lua.o: $(GEN_SRC) src/lua/embedded.h | $(B)/obj
	$(CC) $(ALL_CFLAGS) $(OPT) -Isrc/lua -c -o $@ $<
$(B)/asan/%.o: src/%.c $(HDRS) | $(B)/asan
	@mkdir -p $(@D)
	$(CC) $(ALL_CFLAGS) $(SAN_FLAGS) -c -o $@ $<
$(B)/asan/embedded_lua.o: $(GEN_SRC) src/lua/embedded.h | $(B)/asan
	$(CC) $(ALL_CFLAGS) $(SAN_FLAGS) -Isrc/lua -c -o $@ $<

$(B)/nzlua: $(patsubst src/%.c,$(B)/obj/%.o,$(APP_SRC)) $(OBJ)
	$(CC) $(CFLAGS) $(OPT) -o $@ $^ $(LUA_LIBS) $(GSL_LIBS) $(RL_LIBS) $(DL_LIBS) -lm
# The module links neither liblua (the host provides it) nor readline.
$(B)/nz.so: $(OBJ)
	$(CC) $(CFLAGS) $(OPT) -shared -o $@ $^ $(GSL_LIBS) $(DL_LIBS) -lm
$(B)/asan/nzlua: $(patsubst src/%.c,$(B)/asan/%.o,$(APP_SRC)) $(SAN_OBJ)
	$(CC) $(SAN_FLAGS) -o $@ $^ $(LUA_LIBS) $(GSL_LIBS) $(RL_LIBS) $(DL_LIBS) -lm

# C unit tests of the core, GSL-style PASS/FAIL lines.
$(B)/test_series: tests/test_series.c $(CORE_OBJ) | $(B)
	$(CC) $(ALL_CFLAGS) $(OPT) -o $@ $^ $(GSL_LIBS) $(DL_LIBS) -lm
$(B)/asan/test_series: tests/test_series.c $(SAN_CORE) | $(B)/asan
	$(CC) $(ALL_CFLAGS) $(SAN_FLAGS) -o $@ $^ $(GSL_LIBS) $(DL_LIBS) -lm
$(B)/test_graph: tests/test_graph.c tests/test_util.h $(CORE_OBJ) | $(B)
	$(CC) $(ALL_CFLAGS) $(OPT) -o $@ $(filter-out %.h,$^) $(GSL_LIBS) $(DL_LIBS) -lm
$(B)/asan/test_graph: tests/test_graph.c tests/test_util.h $(SAN_CORE) | $(B)/asan
	$(CC) $(ALL_CFLAGS) $(SAN_FLAGS) -o $@ $(filter-out %.h,$^) $(GSL_LIBS) $(DL_LIBS) -lm
$(B)/test_native: tests/test_native.c tests/test_util.h $(CORE_OBJ) | $(B)
	$(CC) $(ALL_CFLAGS) $(OPT) -o $@ $(filter-out %.h,$^) $(GSL_LIBS) $(DL_LIBS) -lm
$(B)/asan/test_native: tests/test_native.c tests/test_util.h $(SAN_CORE) | $(B)/asan
	$(CC) $(ALL_CFLAGS) $(SAN_FLAGS) -o $@ $(filter-out %.h,$^) $(GSL_LIBS) $(DL_LIBS) -lm
$(B)/test_stepper: tests/test_stepper.c $(CORE_OBJ) | $(B)
	$(CC) $(ALL_CFLAGS) $(OPT) -o $@ $^ $(GSL_LIBS) $(DL_LIBS) -lm
$(B)/asan/test_stepper: tests/test_stepper.c $(SAN_CORE) | $(B)/asan
	$(CC) $(ALL_CFLAGS) $(SAN_FLAGS) -o $@ $^ $(GSL_LIBS) $(DL_LIBS) -lm
$(B)/test_contact: tests/test_contact.c $(CORE_OBJ) | $(B)
	$(CC) $(ALL_CFLAGS) $(OPT) -o $@ $^ $(GSL_LIBS) $(DL_LIBS) -lm
$(B)/asan/test_contact: tests/test_contact.c $(SAN_CORE) | $(B)/asan
	$(CC) $(ALL_CFLAGS) $(SAN_FLAGS) -o $@ $^ $(GSL_LIBS) $(DL_LIBS) -lm
$(B)/bench_jet: bench/bench_jet.c $(CORE_OBJ) | $(B)
	$(CC) $(ALL_CFLAGS) $(OPT) -o $@ $^ $(GSL_LIBS) $(DL_LIBS) -lm
$(B)/bench_motion: bench/bench_motion.c $(CORE_OBJ) | $(B)
	$(CC) $(ALL_CFLAGS) $(OPT) -o $@ $^ $(GSL_LIBS) $(DL_LIBS) -lm
# The hand-written C baselines the benchmarks compare against.
$(B)/henon_c: bench/henon_c.c | $(B)
	$(CC) $(ALL_CFLAGS) $(OPT) -o $@ $^ $(GSL_LIBS) -lm
$(B)/pendulum_c: bench/pendulum_c.c | $(B)
	$(CC) $(ALL_CFLAGS) $(OPT) -o $@ $^ $(GSL_LIBS) -lm

$(B) $(B)/obj $(B)/asan $(B)/gen:
	mkdir -p $@

demo: deps-demo all
	$(B)/nzlua examples/demo.lua

# Every test, normal build then sanitized build; one tally line at the end.
test: deps all $(B)/test_series $(B)/test_graph $(B)/test_native $(B)/test_stepper $(B)/test_contact $(B)/asan/nzlua $(B)/asan/test_series $(B)/asan/test_graph $(B)/asan/test_native $(B)/asan/test_stepper $(B)/asan/test_contact
	@tests/run.sh all

check: deps all $(B)/test_series $(B)/test_graph $(B)/test_native $(B)/test_stepper $(B)/test_contact
	@tests/run.sh plain

sanitize: deps $(B)/asan/nzlua $(B)/asan/test_series $(B)/asan/test_graph $(B)/asan/test_native $(B)/asan/test_stepper $(B)/asan/test_contact all
	@tests/run.sh sanitize

bench: deps all $(B)/bench_jet $(B)/bench_motion $(B)/henon_c $(B)/pendulum_c
	@bench/run.sh

# The differential fuzzer (tests/fuzz/): FUZZ_COUNT random systems, each
# recorded and with compile = false, compared; a new seed each run (printed;
# FUZZ_SEED= repeats one).  tests/fuzz_spec.lua runs a fixed slice.
FUZZ_COUNT ?= 5000
FUZZ_SEED ?=
fuzz: all
	$(B)/nzlua tests/fuzz/run.lua $(FUZZ_COUNT) $(FUZZ_SEED)

# nz.so carries its Lua half inside: one file serves `require "nz"` from any
# Lua 5.4 (the default package.cpath searches $(PREFIX)/lib/lua/5.4).  The
# Jupyter kernel spec "nzlua" goes to $(PREFIX)/share/jupyter/kernels/nzlua
# (Jupyter looks in /usr/local/share/jupyter and /usr/share/jupyter) and
# starts $(PREFIX)/bin/nzlua (docs/kernel.md).
install: deps-kernel all
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(PREFIX)/lib/lua/5.4
	install -m 755 $(B)/nzlua $(DESTDIR)$(PREFIX)/bin/nzlua
	install -m 644 $(B)/nz.so $(DESTDIR)$(PREFIX)/lib/lua/5.4/nz.so
	$(B)/nzlua --install-kernel --prefix $(DESTDIR)$(PREFIX) --nzlua $(PREFIX)/bin/nzlua

uninstall:
	rm -f $(DESTDIR)$(PREFIX)/bin/nzlua $(DESTDIR)$(PREFIX)/lib/lua/5.4/nz.so
	rm -rf $(DESTDIR)$(PREFIX)/share/jupyter/kernels/nzlua

# The kernel spec for you alone, starting this checkout's build/nzlua.
kernel: deps-kernel all
	$(B)/nzlua --install-kernel --user

# docs/notebook.png: examples/classroom_pendulum.ipynb run on this build's
# kernel, rendered by nbconvert and photographed by headless Chromium.
notebook-screenshot: deps all
	rm -rf $(B)/jupyter && $(B)/nzlua --install-kernel --prefix $(B)/jupyter
	JUPYTER_PATH=$(CURDIR)/$(B)/jupyter/share/jupyter /usr/bin/python3 tools/notebook.py execute \
	  examples/classroom_pendulum.ipynb $(B)/classroom_pendulum.ipynb
	/usr/bin/python3 tools/notebook.py html $(B)/classroom_pendulum.ipynb $(B)/classroom_pendulum.html
	/usr/bin/python3 tools/notebook.py screenshot $(B)/classroom_pendulum.html docs/notebook.png 1000 2900

clean:
	rm -rf $(B)
