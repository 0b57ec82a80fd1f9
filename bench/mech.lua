-- mech.lua - the cost of the generalized equations: sys:residual and
-- sys:accel against the number of coordinates k (an n-link pendulum built
-- from particles) and against the order n.  Prints tables (make bench).
local root = (arg and arg[0] or ""):match("^(.-)bench/[^/]*$") or ""
package.path = root .. "?.lua;" .. package.path
local nz = rawget(_G, "nz") or require "nz"
local clock = os.clock

-- An n-link planar pendulum: k particles, each hanging from the previous
-- (bench/chain.lua).
local chain = require "bench.chain"

local function state(k)
  local q, qd, qdd = {}, {}, {}
  for i = 1, k do q[i], qd[i], qdd[i] = 0.1 * i, -0.05 * i, 0.02 * i end
  return q, qd, qdd
end

-- Mean seconds per call over at least 0.3 s.
local function time(f)
  local n, t0 = 0, clock()
  local t
  repeat f(); n = n + 1; t = clock() - t0 until t >= 0.3
  return t / n
end

print("Cost against the number of coordinates k (n-link pendulum from particles)")
print(("%4s %14s %14s %14s"):format("k", "residual n=1", "residual n=2", "accel"))
for _, k in ipairs{ 2, 4, 8, 16 } do
  local sys = chain(k)
  local q, qd, qdd = state(k)
  local r1 = time(function() sys:residual(1, 0, q, qd, qdd) end)
  local r2 = time(function() sys:residual(2, 0, q, qd, qdd) end)
  local a = time(function() sys:accel(0, q, qd) end)
  print(("%4d %11.3f ms %11.3f ms %11.3f ms"):format(k, 1e3 * r1, 1e3 * r2, 1e3 * a))
end

print()
print("Cost against the order n (4-link pendulum, generalized form (3.1))")
print(("%4s %14s %14s"):format("n", "residual", "per order 1"))
local sys = chain(4)
local q, qd, qdd = state(4)
local base
for n = 1, 12 do
  local r = time(function() sys:residual(n, 0, q, qd, qdd) end)
  base = base or r
  print(("%4d %11.3f ms %13.2fx"):format(n, 1e3 * r, r / base))
end
