-- export_spec.lua - sys:export: the equations as code that runs without
-- nzlua.  The C file is compiled here (cc -O2 ... -lgsl) and (1) its main's
-- trajectory (GSL rk8pd) is compared with nzlua's, for a free system and
-- constraints of order 0, 1 (linear and nonlinear in the velocities) and 2,
-- moving or not; (2) a harness that includes it compares its right-hand
-- side with sys:accel and its Jacobian (the derivative of the saddle-point
-- solve on graph derivatives) with nzlua's exact Jacobian from the jets
-- (core.mech.ode_jacobian: another path).  The Python/NumPy and Octave files
-- run where Debian's python3-numpy and octave are installed (python3-numpy
-- comes with `make deps`; octave's tests are marked skipped when it is absent).
local h = require "tests.helpers"
local nz = h.nz
local cs = require "tests.constraint_systems"
local mech = require("nz.core").mech

local dir = os.tmpname()
os.remove(dir)
os.execute("mkdir -p " .. dir)

local function double_pendulum()
  return nz.system{ name = "double pendulum", coords = { "th1", "th2" }, params = { m1 = 1, m2 = 1.5, l1 = 1, l2 = 0.7, g = 9.81 },
    T = function(t, q, qd, P)
      return 0.5 * (P.m1 + P.m2) * P.l1 ^ 2 * qd[1] ^ 2 + 0.5 * P.m2 * P.l2 ^ 2 * qd[2] ^ 2
        + P.m2 * P.l1 * P.l2 * qd[1] * qd[2] * nz.cos(q[1] - q[2])
    end,
    V = function(t, q, P) return -(P.m1 + P.m2) * P.g * P.l1 * nz.cos(q[1]) - P.m2 * P.g * P.l2 * nz.cos(q[2]) end }
end

-- CSV text -> header (list) and rows (lists of numbers)
local function csv(text)
  local rows, head = {}, nil
  for line in text:gmatch("[^\n]+") do
    local fields = {}
    for f in line:gmatch("[^,]+") do fields[#fields + 1] = f end
    if not head then head = fields else
      for n = 1, #fields do fields[n] = tonumber(fields[n]) end
      rows[#rows + 1] = fields
    end
  end
  return head, rows
end

-- The start, on the constraints, for each case, and the run.
local cases = {
  { name = "double pendulum (free)", sys = double_pendulum, q0 = { 1.2, -0.4 }, qd0 = { 0, 0.5 } },
  { name = "Cartesian pendulum (holonomic)", sys = function() return cs.cartesian_pendulum().sys end,
    q0 = { 1.3 * math.sin(1), -1.3 * math.cos(1) }, qd0 = { 0, 0 } },
  { name = "Chaplygin sleigh (nonholonomic, linear)", sys = function() return cs.sleigh().sys end,
    q0 = { 0, 0, 0.3 }, qd0 = { math.cos(0.3), math.sin(0.3), 0.8 } },
  { name = "Appell's constraint (nonlinear in the velocities)", sys = function() return cs.appell().sys end,
    q0 = { 0, 0, 1 }, qd0 = { 0.6, 0.8, 0.6 } },
  { name = "a program constraint on the accelerations", sys = function() return cs.program().sys end,
    q0 = { 0, 0 }, qd0 = { 0.1, -0.05 } },
  { name = "the driven hoop (a moving constraint)", sys = function() return cs.driven_hoop().sys end,
    q0 = { 0.5, 0 }, qd0 = { 0, 4 } },
}

describe("sys:export{lang = 'c'}", function()
  for _, case in ipairs(cases) do
    it(case.name .. ": compiled with GSL, its main's trajectory is nzlua's", function()
      local sys = case.sys()
      local file = dir .. "/sys.c"
      local main = { q0 = case.q0, qd0 = case.qd0, t1 = 3, dt = 0.25, rtol = 1e-11, atol = 1e-11 }
      assert.are.equal(file, sys:export{ lang = "c", file = file, main = main })
      -- with every warning of -Wall -Wextra an error: the file compiles clean
      local rc, _, err = h.run(("cc -O2 -std=c99 -Wall -Wextra -Werror -o %s/sys %s -lgsl -lgslcblas -lm"):format(dir, file))
      assert(rc == 0, "the exported C does not compile without warnings:\n" .. err)
      local rc2, out, err2 = h.run(dir .. "/sys")
      assert(rc2 == 0, err2)
      local head, rows = csv(out)
      local want = { "t" }
      for i = 1, sys.k do want[#want + 1] = sys.coords[i] end
      for i = 1, sys.k do want[#want + 1] = sys.coords[i] .. "'" end
      assert.are.same(want, head)
      local tr = sys:simulate{ q0 = case.q0, qd0 = case.qd0, t1 = 3, dt = 0.25, rtol = 1e-11, atol = 1e-11 }
      assert.are.equal(#tr.t, #rows)
      local worst = 0
      for n = 1, #rows do
        assert.are.equal(tr.t[n], rows[n][1])
        for i = 1, sys.k do
          worst = math.max(worst, math.abs(rows[n][1 + i] - tr.q[n][i]), math.abs(rows[n][1 + sys.k + i] - tr.qd[n][i]))
        end
      end
      -- two integrations to rtol 1e-11 over 3 s (rk8pd on the same
      -- equations, different step sequences): bound 1e-8
      assert(worst <= 1e-8, ("%s: exported and nzlua's motion differ by %.3g"):format(case.name, worst))
    end)
  end

  it("its right-hand side is sys:accel's, its Jacobian the jets' exact one", function()
    for _, case in ipairs{ cases[1], cases[2], cases[3], cases[4], cases[6] } do
      local sys = case.sys()
      local file = dir .. "/sysj.c"
      sys:export{ lang = "c", file = file }
      local points = {}
      for _ = 1, 4 do
        local y = {}
        for i = 1, sys.k do y[i], y[sys.k + i] = case.q0[i] + 0.3 * math.random() - 0.15, case.qd0[i] + 0.4 * math.random() - 0.2 end
        points[#points + 1] = y
      end
      local harness = { ('#include "%s"'):format(file), "int main(void) {", "  static const double ys[][NZX_DIM] = {" }
      for _, y in ipairs(points) do
        local s = {}
        for n = 1, #y do s[n] = ("%.17g"):format(y[n]) end
        harness[#harness + 1] = "    { " .. table.concat(s, ", ") .. " },"
      end
      harness[#harness + 1] = ([[  };
  for (int p = 0; p < %d; p++) {
    double f[NZX_DIM], J[NZX_DIM * NZX_DIM];
    if (nzx_rhs(0.7, ys[p], f) || nzx_jacobian(0.7, ys[p], J)) return 1;
    for (int i = 0; i < NZX_DIM; i++) printf("%%.17g\n", f[i]);
    for (int i = 0; i < NZX_DIM * NZX_DIM; i++) printf("%%.17g\n", J[i]);
  }
  return 0;
}]]):format(#points)
      local hf = assert(io.open(dir .. "/harness.c", "w"))
      hf:write(table.concat(harness, "\n"))
      hf:close()
      local rc, _, err = h.run(("cc -O2 -std=c99 -Wall -Wextra -Werror -o %s/harness %s/harness.c -lm"):format(dir, dir))
      assert(rc == 0, err)
      local rc2, out = h.run(dir .. "/harness")
      assert(rc2 == 0)
      local vals = {}
      for v in out:gmatch("[^\n]+") do vals[#vals + 1] = tonumber(v) end
      local k, dim, at = sys.k, 2 * sys.k, 0
      local orders, linear = {}, {}
      if sys.nc > 0 then orders, linear = require("nz.model.constraints").orders(sys) end
      local ode = mech.ode_new(sys.engine, { method = "rk8pd", rtol = 1e-10, atol = 1e-10, orders = orders, linear = linear })
      for _, y in ipairs(points) do
        local q, qd = { table.unpack(y, 1, k) }, { table.unpack(y, k + 1, dim) }
        local qdd = sys:accel(0.7, q, qd)
        for i = 1, k do
          -- the same equations solved two ways (LU of the saddle-point
          -- matrix here, nzlua's Cholesky and null space there): rounding
          assert(math.abs(vals[at + i] - qd[i]) == 0)
          assert(math.abs(vals[at + k + i] - qdd[i]) <= 1e-12 * (1 + math.abs(qdd[i])),
            ("%s: q''[%d] %.17g vs %.17g"):format(case.name, i, vals[at + k + i], qdd[i]))
        end
        at = at + dim
        local J = mech.ode_jacobian(ode, sys.engine, 0.7, y)
        local scale = 0
        for r = 1, dim do for c = 1, dim do scale = math.max(scale, math.abs(J[r][c])) end end
        for r = 1, dim do
          for c = 1, dim do
            local got = vals[at + (r - 1) * dim + c]
            assert(math.abs(got - J[r][c]) <= 1e-11 * (1 + scale),
              ("%s: J[%d][%d] %.17g, nzlua %.17g"):format(case.name, r, c, got, J[r][c]))
          end
        end
        at = at + dim * dim
      end
    end
  end)

  it("refuses what it cannot write, with the reason", function()
    local ham = cs.hamel().sys
    h.checkerror("constraint 1 is nonlinear in q''", ham.export, ham, { lang = "c" })
    local lua_only = nz.system{ name = "not recorded", coords = { "x" }, compile = false, T = function(t, q, qd) return qd[1] ^ 2 end }
    h.checkerror("the system is not recorded", lua_only.export, lua_only, { lang = "c" })
    -- a piece that fell back to Lua is not in the graph: exporting M and h
    -- without it would write wrong equations (the first version wrote h = 0)
    local branch = nz.system{ name = "branch", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) if q[1] > 0 then return q[1] ^ 2 else return 0 end end }
    h.checkerror("nothing to export: V runs in Lua", branch.export, branch, { lang = "c" })
    local dp = double_pendulum()
    h.checkerror("lang = 'fortran'", dp.export, dp, { lang = "fortran" })
    h.checkerror("main.q0: 2 numbers expected", dp.export, dp, { lang = "c", main = { q0 = { 1 }, t1 = 1, dt = 0.1 } })
    -- a misspelled key of main was ignored (the file used the default method)
    h.checkerror("main: unknown option 'metod' (options: q0, qd0, t0, t1, dt, rtol, atol)", dp.export, dp,
      { lang = "c", main = { q0 = { 1, 0 }, t1 = 1, dt = 0.1, metod = "rk4" } })
    h.checkerror("unknown option 'jacobain' (did you mean 'jacobian'?)", dp.export, dp, { lang = "c", jacobain = false })
  end)
end)

local function have(cmd) return os.execute("command -v " .. cmd .. " >/dev/null 2>&1") == true end
local python = "/usr/bin/python3"
local has_numpy = have(python) and os.execute(python .. " -c 'import numpy' >/dev/null 2>&1") == true

describe("sys:export{lang = 'python'} and {lang = 'octave'}", function()
  for _, lang in ipairs{ "python", "octave" } do
    for _, n in ipairs{ 1, 2, 4 } do
      local case = cases[n]
      it(("%s: %s"):format(lang, case.name), function()
        local runner = lang == "python" and (has_numpy and python) or (have("octave-cli") and "octave-cli --no-gui --quiet")
        if not runner then
          pending(("%s is not installed (%s): the exported file is not run"):format(
            lang == "python" and "python3-numpy" or "octave",
            lang == "python" and "apt-get install python3-numpy" or "apt-get install octave"))
          return
        end
        local sys = case.sys()
        local file = dir .. "/sys." .. (lang == "python" and "py" or "m")
        sys:export{ lang = lang, file = file, main = { q0 = case.q0, qd0 = case.qd0, t1 = 2, dt = 0.5, rtol = 1e-11, atol = 1e-11 } }
        local rc, out, err = h.run(runner .. " " .. file)
        assert(rc == 0, err .. out)
        local head, rows = csv(out)
        assert.are.equal("t", head[1])
        assert.are.equal(sys.coords[1] .. "'", head[2 + sys.k])
        local tr = sys:simulate{ q0 = case.q0, qd0 = case.qd0, t1 = 2, dt = 0.5, rtol = 1e-11, atol = 1e-11 }
        assert.are.equal(#tr.t, #rows)
        local worst = 0
        for p = 1, #rows do
          assert(math.abs(rows[p][1] - tr.t[p]) <= 1e-12)
          for i = 1, sys.k do worst = math.max(worst, math.abs(rows[p][1 + i] - tr.q[p][i])) end
        end
        -- Dormand-Prince 5(4) (Python) or ode45 (Octave) at rtol 1e-11
        -- against rk8pd at 1e-11 over 2 s: bound 1e-7
        assert(worst <= 1e-7, ("%s, %s: the motion differs by %.3g"):format(lang, case.name, worst))
      end)
    end
  end
end)
