-- timing.lua - what the benchmarks against hand-written C share: a wall clock (the
-- same CLOCK_MONOTONIC the C baselines read), the median time of a call,
-- the path of the C baselines, and the graph line (sys:graph_info, when the
-- engine has it).  Speed is measured and printed here, never asserted.
local M = {}

local mech = require("nz.core").mech

-- Wall seconds (CLOCK_MONOTONIC); os.clock (CPU time) when the engine lacks it.
M.now = mech and mech.now or os.clock

-- The repository's root as seen from the running script (bench/x.lua).
M.root = (arg and arg[0] or ""):match("^(.-)bench/[^/]*$") or ""

local function median(xs)
  table.sort(xs)
  local n = #xs
  return n % 2 == 1 and xs[(n + 1) / 2] or 0.5 * (xs[n / 2] + xs[n / 2 + 1])
end
M.median = median

-- Median seconds per call of f, and the number of samples taken.  A sample
-- is `reps` calls together, enough to last o.sample seconds (default
-- 0.02); samples are taken up to o.samples (default 7) within o.budget
-- seconds (default 2), and at least one: a call of 3 s is timed once, a
-- call of 1 us many times.  The first call warms up and, when a sample is
-- one call, counts as the first sample.  o.clock: another clock (os.clock,
-- the process's processor time).
function M.per_call(f, o)
  o = o or {}
  local want_sample, max_samples, budget = o.sample or 0.02, o.samples or 7, o.budget or 2
  local now = o.clock or M.now
  local t0 = now()
  f()
  local first = now() - t0
  local reps = first >= want_sample and 1 or math.ceil(want_sample / math.max(first, 1e-9))
  local nsamples = math.max(1, math.min(max_samples, math.floor(budget / math.max(first * reps, 1e-9))))
  if nsamples > 1 and nsamples % 2 == 0 then nsamples = nsamples - 1 end
  local times = {}
  if reps == 1 then times[1] = first end
  while #times < nsamples do
    local s = now()
    for _ = 1, reps do f() end
    times[#times + 1] = (now() - s) / reps
  end
  return median(times), #times
end

-- Run a command, return its output (an error naming the command if it fails).
function M.run(cmd)
  local p = assert(io.popen(cmd, "r"))
  local out = p:read("a")
  local ok, how, code = p:close()
  if not ok then error(("bench: '%s' failed (%s %s): build it with make bench"):format(cmd, tostring(how), tostring(code)), 0) end
  return out
end

-- The numbers of a line "name v1 v2 ..." of a baseline's output.
function M.vector(out, name)
  local line = out:match("\n" .. name .. " ([^\n]*)")
  if not line then return nil end
  local v = {}
  for x in line:gmatch("%S+") do v[#v + 1] = tonumber(x) end
  return v
end

-- One line on the recorded graph of sys, or nil when the engine records
-- none: node count, recording time, and `per_call` seconds per node.
function M.graph_line(sys, per_call, what)
  if not sys.graph_info then return nil end
  local g = sys:graph_info()
  if type(g) ~= "table" or not g.nodes then return nil end
  local per_node = per_call and g.nodes > 0 and per_call / g.nodes
  return ("graph %d nodes, recorded in %.2f ms%s"):format(g.nodes, 1e3 * (g.record_seconds or 0 / 0),
    per_node and (", %.2f ns/node per %s"):format(1e9 * per_node, what or "call") or "")
end

-- A time in the unit that suits it, width w.
function M.fmt(s, w)
  w = w or 10
  local txt
  if s >= 1 then txt = ("%.3f s"):format(s)
  elseif s >= 1e-3 then txt = ("%.3f ms"):format(1e3 * s)
  elseif s >= 1e-6 then txt = ("%.3f us"):format(1e6 * s)
  else txt = ("%.1f ns"):format(1e9 * s) end
  return (" "):rep(w - #txt) .. txt
end

return M
