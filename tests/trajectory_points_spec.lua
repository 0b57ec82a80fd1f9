-- trajectory_points_spec.lua - a trajectory keeps its points in C (src/lua/
-- lua_points.c) and makes a point's tables only when they are read: tr.q,
-- tr.qd, tr.qdd, tr.lambda, tr:column and tr:csv give the numbers the loop
-- computed, checked against a second path (the integrator's own q'' and
-- lambda at each point, a run on another grid whose points are the same
-- steps' dense output, the CSV read back), and a run of many points costs
-- no table per point.
local h = require "tests.helpers"
local nz = h.nz
local mech = require("nz.core").mech

local henon = nz.system{ name = "Henon-Heiles", coords = { "x", "y" },
  T = function(t, q, qd) return (qd[1] ^ 2 + qd[2] ^ 2) / 2 end,
  V = function(t, q) local x, y = q[1], q[2]; return (x ^ 2 + y ^ 2) / 2 + x ^ 2 * y - y ^ 3 / 3 end }
-- a pendulum on a circle of radius 1 written in (x, y): one multiplier
local circle = nz.system{ name = "circle", coords = { "x", "y" },
  T = function(t, q, qd) return (qd[1] ^ 2 + qd[2] ^ 2) / 2 end,
  V = function(t, q) return 9.81 * q[2] end,
  constraints = { function(t, q) return q[1] ^ 2 + q[2] ^ 2 - 1 end } }

local function taylor(t1, dt)
  return henon:simulate{ q0 = { 0, 0.1 }, qd0 = { 0.5, 0 }, t1 = t1, dt = dt, method = "taylor", rtol = 1e-15,
    atol = 1e-15, progress = false }
end

describe("a trajectory's points", function()
  it("are the integrator's: q'' and lambda at every point are the accelerations there, bit for bit", function()
    local tr = circle:simulate{ q0 = { 1, 0 }, qd0 = { 0, 0 }, t1 = 1, dt = 0.05, progress = false }
    assert.are.equal(21, #tr.t)
    local ode = mech.ode_new(circle.engine, { method = "rk8pd", rtol = 1e-10, atol = 1e-12, h0 = 1e-3,
      orders = { 0 }, linear = { false } })
    for i = 1, #tr.t do
      local y = { tr.q[i][1], tr.q[i][2], tr.qd[i][1], tr.qd[i][2] }
      local qdd, lambda = mech.ode_accel(ode, circle.engine, tr.t[i], y)
      assert.are.same(qdd, tr.qdd[i])
      assert.are.same(lambda, tr.lambda[i])
      assert.are.equal(1, #tr.lambda[i])
    end
  end)

  it("of a fine grid are those of a coarse one at the common times (Taylor: the same steps, dense output)", function()
    local fine, coarse = taylor(20, 0.01), taylor(20, 1)
    assert.are.equal(2001, #fine.t)
    assert.are.equal(21, #coarse.t)
    assert.are.equal(fine.stats.steps, coarse.stats.steps)
    for i = 2, #coarse.t do         -- t = i - 1 is point 100 (i - 1) + 1 of the fine grid
      local j = 100 * (i - 1) + 1
      assert.are.equal(coarse.t[i], fine.t[j])
      for _, f in ipairs{ "q", "qd", "qdd" } do assert.are.same(coarse[f][i], fine[f][j]) end
    end
  end)

  it("read as rows, columns and CSV give the same numbers; a view has the trajectory's length", function()
    local tr = taylor(5, 0.01)
    local n = #tr.t
    assert.are.equal(501, n)
    assert.are.equal(n, #tr.q)
    assert.are.equal(n, #tr.lambda)
    assert.is_nil(tr.q[n + 1])
    assert.is_nil(tr.q[0])
    assert.is_nil(tr.q.x)
    assert.are.equal(tr.q[7], tr.q[7])                    -- made once, then kept
    local count = 0
    for i, row in ipairs(tr.qd) do count = count + 1; assert.are.equal(tr.qd[i], row) end
    assert.are.equal(n, count)
    count = 0
    for _ in pairs(tr.qdd) do count = count + 1 end
    assert.are.equal(n, count)
    assert.are.equal(n, select("#", table.unpack(tr.q)))
    local cols = { x = { "q", 1 }, y = { "q", 2 }, ["x'"] = { "qd", 1 }, ["y''"] = { "qdd", 2 } }
    for name, at in pairs(cols) do
      local col = tr:column(name)
      assert.are.equal(n, #col)
      for i = 1, n do assert.are.equal(tr[at[1]][i][at[2]], col[i]) end
      col[1] = 99                                           -- the caller's own list
      assert.are_not.equal(99, tr:column(name)[1])
    end
    local rows = {}
    for line in tr:csv():gmatch("[^\n]+") do rows[#rows + 1] = line end
    assert.are.equal("t,x,y,x',y',x'',y''", rows[1])
    assert.are.equal(n + 1, #rows)
    for i = 1, n, 50 do
      local v = {}
      for x in rows[i + 1]:gmatch("[^,]+") do v[#v + 1] = tonumber(x) end
      assert.are.same({ tr.t[i], tr.q[i][1], tr.q[i][2], tr.qd[i][1], tr.qd[i][2], tr.qdd[i][1], tr.qdd[i][2] }, v)
    end
  end)


  it("of a contact run with isotropic cones: each multiplier's column is its entry in the rows, by name", function()
    -- a cone's slip speed |v_t| is a row of the contact's series, not a
    -- force: tr.lambda, its names and its columns leave it out alike (two
    -- pucks, so that the first one's speed row lies between the forces)
    local m, mu, g = 1.5, 0.4, 9.81
    local function cone(name, z, x, y)
      return nz.unilateral(function(t, q) return q[z] end, { name = name, mu = mu,
        slip = { function(t, q, qd) return qd[x] end, function(t, q, qd) return qd[y] end } })
    end
    local pucks = nz.system{ name = "two pucks", coords = { "x1", "y1", "z1", "x2", "y2", "z2" },
      T = function(t, q, qd) local s = 0; for i = 1, 6 do s = s + qd[i] ^ 2 end; return 0.5 * m * s end,
      V = function(t, q) return m * g * (q[3] + q[6]) end,
      constraints = { cone("a", 3, 1, 2), cone("b", 6, 4, 5) } }
    for _, method in ipairs{ "rk8pd", "taylor" } do
      local tr = pucks:simulate{ q0 = { 0, 0, 0, 0, 0, 0 }, qd0 = { 1, 1, 0, 2, -1, 0 }, t1 = 0.2, dt = 0.01,
        method = method }
      local names, n = tr.lambda_names, #tr.t
      assert.are.equal(6, #names)
      assert.are.equal(#names, #tr.lambda[1])
      -- each puck slides: N = m g, T opposite its velocity, |T| = mu m g
      local want = { ["N.a"] = m * g, ["N.b"] = m * g, ["T1.a"] = -mu * m * g / math.sqrt(2),
        ["T2.a"] = -mu * m * g / math.sqrt(2), ["T1.b"] = -mu * m * g * 2 / math.sqrt(5),
        ["T2.b"] = mu * m * g / math.sqrt(5) }
      for r, name in ipairs(names) do
        assert(want[name], "an unexpected column " .. name)
        local col = tr:column(name)
        assert(math.abs(col[n] - want[name]) <= 1e-9 * m * g, ("%s: %s = %.17g, want %.17g"):format(method, name,
          col[n], want[name]))
        assert.are.equal(n, #col)
        for i = 1, n do
          assert(col[i] == tr.lambda[i][r], ("%s: %s at point %d is %.17g, the row says %.17g"):format(method, name,
            i, col[i], tr.lambda[i][r]))
        end
      end
    end
  end)

  it("cost no table per point: 20,001 points grow Lua's heap by far less than 20,001 tables", function()
    taylor(200, 200)
    collectgarbage()
    collectgarbage()
    local before = collectgarbage("count")
    local tr = taylor(200, 0.01)
    collectgarbage()
    collectgarbage()
    local grown = collectgarbage("count") - before
    assert.are.equal(20001, #tr.t)
    -- tr.t alone is 20,001 numbers (16 bytes each: 313 KB); four tables of
    -- two numbers per point, as before, were over 7 MB
    assert.is_true(grown < 1024, ("the heap grew by %.0f KB"):format(grown))
    assert.are.equal(tr.q[20001][1], tr:column("x")[20001])
  end)
end)
