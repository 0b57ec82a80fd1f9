-- fuzz_spec.lua - a fixed-seed slice of the differential fuzzer
-- (tests/fuzz/): random systems over every operation a recording holds
-- (parameters, constant and varying M, Q, holonomic and nonholonomic
-- constraints), each recorded and with compile = false, compared on values,
-- jets with tangents, state directions, M, h, accelerations, residuals of
-- orders 1-3, energies and short runs, at random and boundary states.  A
-- finding prints the system's source.  `make fuzz` runs a longer slice
-- from a new seed; the classes it found once are named tests in
-- tests/fidelity_spec.lua.
local h = require "tests.helpers"
local compare = require "tests.fuzz.compare"
local systems = require "tests.fuzz.systems"
local _ = h.nz

describe("the differential fuzzer", function()
  it("finds no difference between the recorded systems and Lua (250 systems, seed 20261201)", function()
    local findings, comparisons, tried = compare.run(20261201, 250)
    local text = {}
    for i = 1, math.min(#findings, 3) do text[i] = compare.describe(findings[i]) end
    assert(#findings == 0, ("%d findings in %d comparisons of %d systems; the first:\n%s"):format(#findings,
      comparisons, tried, table.concat(text, "\n\n")))
    assert.is_true(comparisons > 10000, comparisons .. " comparisons")
  end)

  it("makes every kind of system it promises, and boundary states", function()
    local r = systems.rng(7)
    local seen = { constant_M = 0, varying_M = 0, Q = 0, holonomic = 0, nonholonomic = 0, smooth = 0 }
    for _ = 1, 200 do
      local s = systems.system(r)
      seen[s.constant_M and "constant_M" or "varying_M"] = seen[s.constant_M and "constant_M" or "varying_M"] + 1
      if s.source:find("Q = function", 1, true) then seen.Q = seen.Q + 1 end
      if s.source:find("return q%[2%] %- %(") then seen.holonomic = seen.holonomic + 1 end
      if s.source:find("return qd%[2%] %- %(") then seen.nonholonomic = seen.nonholonomic + 1 end
      if s.smooth then seen.smooth = seen.smooth + 1 end
    end
    for kind, n in pairs(seen) do assert(n >= 5, ("only %d systems with %s"):format(n, kind)) end
    local zeros = 0
    for _, st in ipairs(systems.states(r, 3, 0, 50)) do
      for i = 1, 3 do if st.q[i] == 0 then zeros = zeros + 1 end end
    end
    assert.is_true(zeros >= 20, zeros .. " zero coordinates among 150")
  end)
end)
