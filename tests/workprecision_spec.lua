-- workprecision_spec.lua - nz.workprecision: what accuracy costs in time.
-- The errors are checked against a closed form written here (the harmonic
-- oscillator), the table's rows against the runs themselves, and the
-- flags (a grid that sets the steps, methods that do not apply) against
-- what each run did.
local h = require "tests.helpers"
local nz = h.nz

local w = 1.5
local oscillator = nz.system{ name = "wp oscillator", coords = { "x" },
  T = function(t, q, qd) return qd[1] ^ 2 / 2 end, V = function(t, q) return w * w * q[1] ^ 2 / 2 end }
local function exact(t) return { math.cos(w * t) } end

describe("nz.workprecision", function()
  it("one row per method and tolerance, errors against the closed form, tighter is more accurate", function()
    local rows = nz.workprecision(oscillator, { q0 = { 1 }, qd0 = { 0 }, t1 = 10, dt = 1, methods = { "rk8pd", "taylor" },
      tols = { 1e-5, 1e-10 }, reference = exact, quiet = true })
    assert.are.equal(4, #rows)
    local by = {}
    for _, r in ipairs(rows) do
      assert.are.equal("done", r.status)
      by[r.method .. r.tol] = r
      -- the error is the run's own, against cos(w t) on the grid (rtol = tol, atol = tol / 100):
      -- measured at most 30 tol over these 15 periods
      local tr = oscillator:simulate{ q0 = { 1 }, qd0 = { 0 }, t1 = 10, dt = 1, method = r.method, rtol = r.tol,
        atol = r.tol * 1e-2 }
      local worst = 0
      for i = 1, #tr.t do worst = math.max(worst, math.abs(tr.q[i][1] - exact(tr.t[i])[1])) end
      assert.are.equal(worst, r.error)
      assert(r.error <= 1e2 * r.tol, ("%s at %g: error %.3g"):format(r.method, r.tol, r.error))
      assert(r.time > 0 and r.nfev > 0 and r.steps > 0)
    end
    assert(by["rk8pd1e-10"].error < by["rk8pd1e-05"].error)
    assert(by["rk8pd1e-10"].nfev > by["rk8pd1e-05"].nfev)
  end)

  it("flags the rows whose steps the output grid set, and says so under the table", function()
    -- dt = 0.01 over 10 s: 1000 outputs, more than rk8pd needs at 1e-5
    -- (about 60 steps with dt = 10); rk8pd reads its points off its dense
    -- output and taylor off the series; msbdf (no dense output unless
    -- asked) and rk8pd with dense = false stop at every output time
    local rows = nz.workprecision(oscillator, { q0 = { 1 }, qd0 = { 0 }, t1 = 10, dt = 0.01,
      methods = { "rk8pd", "taylor", "msbdf" }, tols = { 1e-5 }, reference = exact, quiet = true })
    local text = require("nz.workprecision").table(rows)
    assert.is_false(rows[1].grid)
    assert(rows[1].steps < 100, rows[1].steps)
    assert.is_false(rows[2].grid)
    assert(rows[2].steps < 100, rows[2].steps)
    assert.is_true(rows[3].grid)
    assert.truthy(text:find("%(grid%)"), text)
    assert.truthy(text:find("the output grid, not the tolerance, set these steps", 1, true), text)
    local off = nz.workprecision(oscillator, { q0 = { 1 }, qd0 = { 0 }, t1 = 10, dt = 0.01, simulate = { dense = false },
      methods = { "rk8pd" }, tols = { 1e-5 }, reference = exact, quiet = true })
    assert.is_true(off[1].grid)
    assert(off[1].steps >= 1000, off[1].steps)
    local coarse = nz.workprecision(oscillator, { q0 = { 1 }, qd0 = { 0 }, t1 = 10, dt = 10,
      methods = { "rk8pd" }, tols = { 1e-5 }, reference = exact, quiet = true })
    assert.is_false(coarse[1].grid)
    assert.is_nil(require("nz.workprecision").table(coarse):find("(grid)", 1, true))
  end)

  it("a method that does not apply gets one row that says why", function()
    local osc = nz.system{ name = "oscillator in Lua", coords = { "x" }, compile = false,
      T = function(t, q, qd) return qd[1] ^ 2 / 2 end, V = function(t, q) return q[1] ^ 2 / 2 end }
    local rows = nz.workprecision(osc, { q0 = { 1 }, t1 = 1, dt = 0.5,
      methods = { "rk8pd", "taylor" }, tols = { 1e-6, 1e-8 }, quiet = true })
    local text = require("nz.workprecision").table(rows)
    local skipped = 0
    for _, r in ipairs(rows) do
      if r.method == "taylor" then
        assert.are.equal("skipped", r.status)
        assert.are.equal("skipped: not recorded", r.message)
        skipped = skipped + 1
      else
        assert.are.equal("done", r.status)
      end
    end
    assert.are.equal(2, skipped)
    assert.truthy(text:find("skipped: not recorded", 1, true), text)
  end)

  it("taylor's rows for a system with a velocity constraint (the sleigh), against rk8pd's reference", function()
    local cs = require "tests.constraint_systems"
    local s = cs.sleigh()
    local rows = nz.workprecision(s.sys, { q0 = { 0, 0, 0 }, qd0 = { 1, 0, 0.5 }, t1 = 5, dt = 0.5,
      methods = { "taylor" }, tols = { 1e-6, 1e-9 }, quiet = true })
    for _, r in ipairs(rows) do
      assert.are.equal("done", r.status)
      -- the global error against rk8pd at 1e-13: within 10 tol (measured
      -- far below: taylor's steps keep well inside their tolerance)
      assert(r.error <= 10 * r.tol, ("tol %g: error %.3g"):format(r.tol, r.error))
    end
  end)
end)
