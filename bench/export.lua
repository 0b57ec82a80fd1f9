-- export.lua - what sys:export's C costs and gives: the exported
-- accelerations of the n-link pendulum (bench/chain.lua; k = 8, 16) against
-- the same equations written by hand in C (build/pendulum_c, run in the same
-- benchmark), and the Whipple bicycle's exported constrained accelerations
-- against nzlua's own sys:accel; with the time nzlua takes to write the
-- file, the file's size, and the C compiler's time on it.
--   build/nzlua bench/export.lua
local root = (arg and arg[0] or ""):match("^(.-)bench/[^/]*$") or ""
package.path = root .. "?.lua;" .. package.path
local nz = rawget(_G, "nz") or require "nz"
local timing = require "bench.timing"
local chain = require "bench.chain"

local dir = os.tmpname()
os.remove(dir)
os.execute("mkdir -p " .. dir)

-- A harness that includes the exported file and prints the median time of
-- nzx_accel at a state (ns), and q'' there.
local function time_exported(file, q, qd, k)
  local function list(v) local s = {}; for i = 1, #v do s[i] = ("%.17g"):format(v[i]) end; return table.concat(s, ", ") end
  local src = ([[
#include <time.h>
#include "%s"
static double now(void) { struct timespec ts; clock_gettime(CLOCK_MONOTONIC, &ts); return ts.tv_sec + 1e-9 * ts.tv_nsec; }
static int cmp(const void *a, const void *b) { double x = *(const double *)a, y = *(const double *)b; return (x > y) - (x < y); }
int main(void)
{
  double q[%d] = { %s }, qd[%d] = { %s }, qdd[%d], lam[NZX_NC + 1], times[9], sink = 0;
  long reps = 1;
  for (;;) {
    double t0 = now();
    for (long r = 0; r < reps; r++) { q[0] += 1e-300; nzx_accel(0, q, qd, qdd, lam); sink += qdd[0]; }
    if (now() - t0 > 0.01) break;
    reps *= 2;
  }
  for (int s = 0; s < 9; s++) {
    double t0 = now();
    for (long r = 0; r < reps; r++) { q[0] += 1e-300; nzx_accel(0, q, qd, qdd, lam); sink += qdd[0]; }
    times[s] = (now() - t0) / reps;
  }
  qsort(times, 9, sizeof times[0], cmp);
  printf("%%.3f %%g\n", 1e9 * times[4], sink * 0);
  for (int i = 0; i < %d; i++) printf("%%.17g\n", qdd[i]);
  return 0;
}
]]):format(file, k, list(q), k, list(qd), k, k)
  local h = assert(io.open(dir .. "/harness.c", "w"))
  h:write(src)
  h:close()
  local t0 = timing.now()
  timing.run(("cc -O2 -o %s/harness %s/harness.c -lm"):format(dir, dir))
  local compile = timing.now() - t0
  local out = timing.run(dir .. "/harness")
  local ns = tonumber(out:match("^(%S+)"))
  local qdd = {}
  for v in out:gmatch("\n(%S+)") do qdd[#qdd + 1] = tonumber(v) end
  return ns * 1e-9, qdd, compile
end

local function size_of(file)
  local f = assert(io.open(file))
  local n = #f:read("a")
  f:close()
  return n
end

-- the state of bench/pendulum_c.c
local function state(k)
  local q, qd = {}, {}
  for i = 1, k do q[i], qd[i] = 0.7 * math.sin(1.3 * i + 0.5), 0.9 * math.cos(0.7 * i + 0.2) end
  return q, qd
end

local function c_times()
  local out = timing.run(root .. "build/pendulum_c")
  local ns = {}
  for k, v in out:gmatch("\n%s*(%d+)%s+([%d.]+)") do ns[tonumber(k)] = tonumber(v) * 1e-9 end
  return ns
end

print("sys:export{lang = 'c'}: the exported accelerations (compiled -O2) against hand-written C and nzlua")
print(("%-30s %10s %10s %10s %8s %12s %10s %10s"):format("system", "exported", "baseline", "", "ratio", "export time",
  "file", "cc -O2"))
for _, k in ipairs{ 8, 16 } do
  local sys = chain(k)
  local q, qd = state(k)
  local file = ("%s/chain%d.c"):format(dir, k)
  local t0 = timing.now()
  sys:export{ lang = "c", file = file }
  local t_export = timing.now() - t0
  local fileNJ = ("%s/chain%d_nojac.c"):format(dir, k)
  t0 = timing.now()
  sys:export{ lang = "c", file = fileNJ, jacobian = false }
  local t_nj = timing.now() - t0
  local c1 = c_times()[k]
  local t_exp, qdd, cc = time_exported(fileNJ, q, qd, k)
  local c2 = c_times()[k]
  local base = 0.5 * (c1 + c2)
  local want = sys:accel(0, q, qd)
  local worst = 0
  for i = 1, k do worst = math.max(worst, math.abs(qdd[i] - want[i]) / (1 + math.abs(want[i]))) end
  print(("%-30s %10s %10s %10s %8.2f %12s %9.0fk %10s   (q'' agrees with nzlua to %.1e)"):format(("%d-link pendulum"):format(k),
    timing.fmt(t_exp), timing.fmt(base), "hand C", t_exp / base, timing.fmt(t_nj), size_of(fileNJ) / 1024, timing.fmt(cc), worst))
  print(("%-30s %10s %10s %10s %8s %12s %9.0fk"):format("  with its Jacobian", "", "", "", "", timing.fmt(t_export),
    size_of(file) / 1024))
end

-- The Whipple bicycle: constrained accelerations (8 coordinates, 5 constraints).
local model = loadfile(root .. "examples/bicycle.lua")("module")
local bike = model.system
local q, qd = model.state(0.05, 0.1, 0.2, -0.1, -5 / model.params.rR)
local file, fileNJ = dir .. "/bicycle.c", dir .. "/bicycle_nojac.c"
local t0 = timing.now()
bike:export{ lang = "c", file = file }
local t_export = timing.now() - t0
t0 = timing.now()
bike:export{ lang = "c", file = fileNJ, jacobian = false }
local t_nj = timing.now() - t0
local t_exp, qdd, cc = time_exported(fileNJ, q, qd, 8)
bike:accel(0, q, qd)
local mine = timing.per_call(function() bike:accel(0, q, qd) end, { budget = 1.0 })
local want = bike:accel(0, q, qd)
local worst = 0
for i = 1, 8 do worst = math.max(worst, math.abs(qdd[i] - want[i]) / (1 + math.abs(want[i]))) end
print(("%-30s %10s %10s %10s %8.2f %12s %9.0fk %10s   (q'' agrees with nzlua to %.1e)"):format("Whipple bicycle (constrained)",
  timing.fmt(t_exp), timing.fmt(mine), "sys:accel", t_exp / mine, timing.fmt(t_nj), size_of(fileNJ) / 1024,
  timing.fmt(cc), worst))
print(("%-30s %10s %10s %10s %8s %12s %9.0fk"):format("  with its Jacobian", "", "", "", "", timing.fmt(t_export), size_of(file) / 1024))
print("(ratio: exported / baseline time per accelerations (the file without its Jacobian, compiled -O2 here); export time:")
print(" nzlua writing the file; the exported solve is a dense LU of the saddle-point matrix, the hand-written C a Cholesky of M;")
print(" the Jacobian's code grows as k^3 terms: the 16-link's takes ~10 s to compile, the bicycle's ~50 s, jacobian = false leaves it out)")
os.execute("rm -rf " .. dir)
