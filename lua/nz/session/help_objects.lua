-- nz/session/help_objects.lua - help(sys), help(tr), help(lin), help(sw): what the
-- objects a session is full of are, every field they hold and each method
-- in one line, with a pointer to the long help.  The fields of a
-- trajectory (events, statistics, ...) are documented here and nowhere
-- else; tests/help_spec.lua checks that every field an object really holds
-- and every method of its class has its line.
local M = {}

-- Each object: its class, its name in the text (the prefix of its
-- methods), a title, where the long help is, the fields in the order shown
-- ({name, text}; a name "events[e]" documents the list events), groups of
-- subfields ({title, prefix, fields}), the methods' lines.
local function system()
  return {
    class = require("nz.base.classes").System, prefix = "sys", what = "a mechanical system (nz.system{...}, nz.scene{...})",
    title = function(sys)
      return ("a mechanical system, nz.system '%s': %d coordinate%s (%s)%s"):format(sys.name, sys.k,
        sys.k == 1 and "" or "s", table.concat(sys.coords, ", "),
        sys.nc > 0 and (", %d constraint%s"):format(sys.nc, sys.nc == 1 and "" or "s") or "")
    end,
    long = "help(nz.system) explains systems, their definition and every method in full; help(sys.NAME) one "
      .. "method; print(sys) says which functions run in C and which in Lua",
    fields = {
      { "name", "the name messages use" },
      { "coords", "the names of the k coordinates, in the order of q[1], q[2], ..." },
      { "k", "the number of coordinates" },
      { "nc", "the number of constraints" },
      { "params", "the named parameters every function receives: set sys.params.m = 3 and the next call uses it" },
      { "sample", "the typical state given in nz.system{sample = ...}, near which the constraints are "
        .. "classified and the functions tried (nil: the defaults)" },
      { "pieces", "how many functions T, V, Q, L and S each have (pieces.T, ...)" },
      { "constraint_levels", "per constraint, the derivative slots it receives (q, qd, qdd, ...)" },
      { "bodies", "the bodies of nz.system{bodies = ...} or of a scene, which tr:animate draws" },
      { "effects", "a scene's effects, by kind (nz.scene)" },
      { "gravity", "a scene's gravity (its gravity effect's g), against which tr:animate{view = \"3d\"} puts up" },
      { "contact", "with unilateral contacts (help(nz.unilateral)): their names and parameters, and the system a "
        .. "run integrates them with (contact.system: the constraints, then each gap and slip function)" },
      { "recording", "what was recorded as graphs evaluated in C, per function (print(sys) shows it; "
        .. "sys:graph_info() its size); nil with compile = false" },
      { "engine", "what the C mechanics reads (the pieces, the recording): internal" },
      { "parent", "sys:parametric and sys:jacobi_whittaker: the system it was made from" },
      { "time_index", "sys:parametric: the coordinate that is the time" },
      { "h", "sys:jacobi_whittaker: the energy of the paths" },
      { "independent", "sys:jacobi_whittaker: the coordinate that plays the time" },
      { "time_rate", "sys:jacobi_whittaker: path:time_rate(q1, q, qd), dt/dphi at a point of the path" },
      { "elapsed", "sys:jacobi_whittaker: path:elapsed(tr), the physical time at each point of a path" },
      { "time_system", "sys:jacobi_whittaker: path.time_system(), the path with the elapsed time as one more "
        .. "coordinate (what path:elapsed integrates)" },
    },
    methods = {
      residual = "the k residuals of the equations of order n at a state, in any form (docs/theory.md (3.1))",
      equations = "print the terms of the equations of order n at a state, per coordinate",
      accel = "the accelerations q'' (and multipliers lambda) at a state",
      mass = "the mass matrix M of M q'' + h = 0",
      bias = "h of M q'' + h = 0 (forces, dV/dq and velocity terms)",
      mass_bias = "M and h at once",
      energy = "T + V, the generalized energy H, and whether H is a first integral",
      reaction_power = "R_0, the power of the reactions of moving constraints (docs/theory.md (9.1))",
      constraints = "each constraint's order, linearity, homogeneity, with the evidence (prints as a table)",
      rule = "Dolapchiev's n and why (the order of the equations the constraints need)",
      reduced = "accelerations from Tsenov's reduced equations, without multipliers",
      project = "the nearest state on the constraints",
      check_state = "an error if a state violates the constraints",
      simulate = "integrate the motion: a trajectory tr (help(tr))",
      linearize = "the motion linearized about an equilibrium: lin (help(lin))",
      equilibrium = "an equilibrium or a steady motion near a guess (Newton)",
      eigen_sweep = "the eigenvalues against a parameter, where stability changes: sw (help(sw))",
      show = "the equations as formulas: text, LaTeX, Lua",
      export = "the equations as C, Python or Octave code that runs without nzlua",
      residuals_of = "the defect of points computed or measured elsewhere",
      report = "a classroom summary: the rule, residuals of two orders, a run, a plot",
      graph_info = "the recording's size and what runs as machine code",
      parametric = "the system with the time as a coordinate (Rumyantsev)",
      energy_integral = "whether H = T2 - T0 + V is a first integral, and why",
      energy_theorem = "the drift of H and of T + V - W along a trajectory",
      jacobi_whittaker = "with the energy fixed, the path as a system in another 'time'",
    },
  }
end

local function trajectory()
  return {
    class = require("nz.motion.trajectory").Trajectory, prefix = "tr", what = "a trajectory (sys:simulate{...})",
    title = function(tr)
      local n = #tr.t
      return ("a trajectory of '%s' (sys:simulate): %d point%s%s, status %s"):format(tr.system.name, n,
        n == 1 and "" or "s", n > 0 and (", t = %.6g .. %.6g"):format(tr.t[1], tr.t[n]) or "", tostring(tr.status))
    end,
    long = "help(nz.system) explains sys:simulate's options; help(tr.NAME) one method; print(tr) sums the run up",
    fields = {
      { "t", "tr.t[i]: the time of output point i (t0, t0 + dt, ..., t1; up to the event that stopped the run)" },
      { "q", "tr.q[i][j]: coordinate j at point i (tr:column(\"th\") gives one coordinate's list)" },
      { "qd", "tr.qd[i][j]: its velocity (tr:column(\"th'\"))" },
      { "qdd", "tr.qdd[i][j]: its acceleration, solved from the equations there (tr:column(\"th''\"))" },
      { "lambda", "tr.lambda[i][r]: the multiplier of constraint r ({} without constraints; "
        .. "tr:column(\"lambda1\"))" },
      { "higher", "constraints of order p > 3: tr.higher[i] = {q''', ..., q^(p-1)}, the state's higher levels "
        .. "(tr:column(\"th'''\"))" },
      { "top", "a constraint of order p nonlinear in q^(p): tr.top[i], q^(p) solved at each point" },
      { "branch", "that constraint's first root and how Newton started: {from = \"guess\" | \"least squares\", "
        .. "q3d =, lambda =}" },
      { "violation", "tr.violation[i]: with constraints, how far the state is from them (tr:column(\"violation\"))" },
      { "energy", "monitors = {energy = true}: tr.energy[i] = T + V (tr:column(\"E\"))" },
      { "generalized_energy", "monitors = {energy = true}: H = sum qd dL/dqd - L (tr:column(\"H\"))" },
      { "work", "monitors = {work = true}: the work W of the moving constraints' reactions and of Q "
        .. "(tr:column(\"work\"))" },
      { "events", "tr.events[e]: each located crossing of simulate's events, in time order (below)" },
      { "contacts", "with unilateral contacts: .names, .modes[i] = {t, states} (each mode from its start), "
        .. ".impacts, .zeno (each rest after impacts accumulating: .accumulation, the time they predicted, .t, the "
        .. "rest's start, .contact), .final (the last mode)" },
      { "lambda_names", "with unilateral contacts: the names of tr.lambda's columns, lambda1, ..., then N.name and "
        .. "T.name (each contact's normal and friction force: tr:column(\"N.floor\"); T1.name, T2.name for an "
        .. "isotropic cone)" },
      { "projections", "project = true: how many times the state was projected onto the constraints" },
      { "status", "\"done\"; \"stopped\" (an event with stop = true); \"interrupted\" (Ctrl-C: the part computed); "
        .. "\"failed\" (the error said why; nz.last holds the part computed)" },
      { "message", "why the run stopped, when it stopped early" },
      { "warnings", "the warnings the run gave (said once on stderr): options that do nothing, a long run, ..." },
      { "stats", "what the run cost and how it ran (below)" },
      { "system", "the system simulated" },
      { "coords", "its coordinates' names" },
      { "method", "the method (\"rk8pd\", \"taylor\", ...)" },
      { "rtol", "the relative tolerance" },
      { "atol", "the absolute tolerance" },
      { "step", "the fixed step, or nil (adaptive)" },
    },
    groups = {
      { title = "Each event crossing, tr.events[e]", prefix = ".", key = "events", fields = {
        { "name", "the event's name (events = {{name = \"x=0\", f = ...}}; else \"event n\")" },
        { "t", "the time of the crossing, located to event_tol (1e-12)" },
        { "q", "the coordinates there: tr.events[e].q[j]" },
        { "qd", "the velocities there (a contact's: before its impact)" },
        { "direction", "1 when the event's f rose through zero, -1 when it fell (not a contact's)" },
        { "contact", "a contact's event: the contact's number; its name is .name" },
        { "kind", "a contact's event: \"impact\", \"closes\", \"opens\", \"sticks\" or \"slips\"" },
        { "qd_after", "a contact's event: the velocities after it (an impact's q'+)" },
        { "from", "a contact's event: its state before (\"open\", \"closed\", \"stick\", \"slip+\", \"slip-\"; "
          .. "\"slip\" for an isotropic cone)" },
        { "to", "a contact's event: its state after" },
        { "gap", "a contact's event: its gap there (0 within the event's tolerance)" },
        { "normal_velocity", "a contact's event: its normal velocity before" },
        { "slip_velocity", "a contact's event: its slip velocity before (0 without friction; {x, y} for an isotropic cone)" },
        { "impulse", "an impact: this contact's normal impulse P (Lagrange's impulse equations); every contact "
          .. "taking an impulse has its event (Newton's cradle: the touching pair's too)" },
        { "tangential_impulse", "an impact: the friction's impulse ({x, y} for an isotropic cone)" },
        { "speed", "an impact: the approach speed -v- (0 for a contact touching at rest)" },
        { "energy_lost", "an impact: the kinetic energy it took (on its first contact when several)" },
        { "zeno", "an impact made plastic: the time its impacts accumulate at (Zeno)" },
      }, note = "Which crossings count is the event's direction (1: rising, -1: falling, 0: both, the default); "
        .. "stop = true ends the run at the first.  tr:section{when = \"x=0\"} draws them." },
      { title = "The run's statistics, tr.stats", prefix = ".", key = "stats", fields = {
        { "steps", "the steps accepted" },
        { "rejected", "the steps rejected by the error control" },
        { "nfev", "the right-hand sides evaluated (taylor: the series of the motion computed)" },
        { "njev", "the Jacobians evaluated (implicit methods)" },
        { "order", "the order of the method (taylor: the highest order used)" },
        { "wall", "the seconds the stepping took (wall clock)" },
        { "events_why", "why the event functions are called in Lua (one that cannot be recorded, ...)" },
        { "interpolated", "the output points read off a step's interpolant (dense output)" },
        { "forced", "the output points the interpolant's error control made step ends" },
        { "grid_why", "why the output grid set the steps, when it did (nz.workprecision marks them (grid))" },
        { "evaluator", "what evaluated the equations: machine code, the interpreted graph, or jets in Lua" },
        { "native_from_step", "the step from which machine code ran, when it took over during the run" },
        { "reversed", "{constraint =, ta =, tb =}: a constraint's gradient passed through zero in that step" },
      } },
    },
    methods = {
      column = "the values of a quantity along the motion: \"th\", \"th'\", \"t\", \"E\", \"lambda1\", ...",
      plot = "draw quantities against t (or each other) in the terminal, or to an SVG or PNG",
      csv = "the points as CSV, to a file or as text",
      residuals = "the defect of the motion: how far the points are from satisfying the equations",
      consistency = "the forms of order n at the run's own q'': rounding, a check of the engine",
      section = "a Poincare section from the run's event crossings",
      animate = "the mechanism frame by frame: terminal, GIF or SVG frames; view = \"3d\": the bodies in space",
    },
  }
end

local function linear()
  return {
    class = require("nz.analysis.linearize").Linear, prefix = "lin", what = "a linearization (sys:linearize{...})",
    title = function(lin)
      return ("a linearization of '%s' (sys:linearize) at t = %g: state (%s)"):format(lin.system.name, lin.t,
        table.concat(lin.state, ", "))
    end,
    long = "help(sys.linearize) explains the options and the choices made; print(lin) shows the modes",
    fields = {
      { "A", "x' = A x: the linearized motion in the kept state (exact, from jets)" },
      { "state", "the kept state's names: the kept coordinates, then the kept speeds (\"th'\")" },
      { "M", "M q'' + C q' + K q = 0, when the kept speeds are the kept coordinates': the reduced mass matrix" },
      { "C", "the damping and gyroscopic matrix" },
      { "K", "the stiffness matrix" },
      { "t", "the time of the point" },
      { "q", "the point's coordinates, the dependent ones solved" },
      { "qd", "its velocities, the dependent ones solved" },
      { "qdd", "the accelerations there" },
      { "residual", "the largest kept acceleration at the point: 0 at an equilibrium or a steady motion" },
      { "coords", "the kept coordinates (numbers)" },
      { "speeds", "the kept speeds (numbers)" },
      { "hold", "the speeds held at their values (hold = {...})" },
      { "dependent", "the coordinates solved from the holonomic constraints" },
      { "dependent_speeds", "the speeds solved from the velocity constraints" },
      { "ignorable", "the coordinates dropped: they do not appear in the kept equations" },
      { "position_newton", "{iterations, residual} of the Newton solve of the dependent coordinates" },
      { "velocity_newton", "the same for the dependent speeds (nonlinear velocity constraints)" },
      { "vectors", "the eigenvectors, after lin:eigenvalues(), in its order" },
      { "system", "the system linearized" },
    },
    groups = {
      { title = "Each mode, lin:modes()[m]", prefix = ".", key = "modes", fields = {
        { "re", "the real part of the eigenvalue: its growth rate (1/s)" },
        { "im", "the imaginary part (a complex pair is one mode)" },
        { "omega", "the frequency |im| in rad/s" },
        { "hz", "the frequency in Hz" },
        { "damping", "the damping ratio -re / |lambda|" },
        { "stable", "\"stable\", \"neutral\" (on the imaginary axis, within rounding) or \"unstable\"" },
        { "shape", "the amplitude of each kept coordinate, the largest 1" },
        { "phase", "the phase of each relative to the largest, in radians (print(lin) writes a@p)" },
      } },
    },
    methods = {
      eigenvalues = "the eigenvalues {re, im} of A, the fastest growing first",
      modes = "one row per mode: frequency, damping, stability and shape",
    },
  }
end

local function sweep()
  return {
    class = require("nz.analysis.eigen_sweep").Sweep, prefix = "sw", what = "an eigenvalue sweep (sys:eigen_sweep{...})",
    title = function(sw)
      return ("an eigenvalue sweep of '%s' (sys:eigen_sweep) against %s: %d values, %d change%s of stability")
        :format(sw.system.name, sw.parameter, #sw.rows, #sw.crossings, #sw.crossings == 1 and "" or "s")
    end,
    long = "help(sys.eigen_sweep) explains the options; print(sw) shows the table",
    fields = {
      { "rows", "sw.rows[i]: the linearization at each value (below)" },
      { "crossings", "sw.crossings[c]: where the stability changes, located to tol (below)" },
      { "parameter", "the parameter's name (parameter = \"v\")" },
      { "tol", "the tolerance the changes were located to" },
      { "system", "the system swept" },
    },
    groups = {
      { title = "Each value, sw.rows[i]", prefix = ".", key = "rows", fields = {
        { "value", "the parameter's value" },
        { "eigenvalues", "the eigenvalues {re, im}, the fastest growing first" },
        { "status", "\"stable\", \"neutral\" or \"unstable\"" },
        { "abscissa", "the largest real part" },
        { "leading", "the eigenvalue with the largest real part" },
        { "threshold", "what counts as zero for a real part there: 1e-8 (1 + max |A_ij|)" },
        { "residual", "lin.residual there" },
      } },
      { title = "Each change of stability, sw.crossings[c]", prefix = ".", key = "crossings",
        fields = {
          { "value", "where the stability changes" },
          { "from", "the status below it" },
          { "to", "the status above it" },
          { "kind", "\"oscillatory\" or \"real\": the mode that changes" },
          { "frequency", "that mode's frequency (rad/s)" },
          { "eigenvalue", "that mode's eigenvalue {re, im} where it was read" },
          { "how", "how it was located: Brent's method, or bisection on the status" },
        } },
    },
    methods = {
      csv = "the sweep as CSV (re and im of each eigenvalue, the status), to a file or as text",
      plot = "the real and imaginary parts against the parameter, in the terminal or to a file",
    },
  }
end

local function objects() return { system(), trajectory(), linear(), sweep() } end
M.objects = objects

-- The description of the object `obj` (one of the four), or nil.
function M.find(obj)
  if type(obj) ~= "table" and type(obj) ~= "string" then return nil end
  local mt = type(obj) == "table" and getmetatable(obj)
  for _, o in ipairs(objects()) do
    if (mt and mt == o.class) or obj == o.prefix then return o end
  end
end

-- The help text of an object: what it is, its fields, its methods.
function M.text(o, obj)
  local wrap = require("nz.base.text").wrap
  local out = {}
  local title = type(obj) == "table" and o.title(obj) or nil
  out[#out + 1] = wrap(("%s: %s"):format(o.prefix, title or o.what), "", "  ")
  out[#out + 1] = wrap(o.long .. ".", "", "")
  out[#out + 1] = ""
  out[#out + 1] = "Fields"
  local pad = (" "):rep(22)
  local function field_lines(list, prefix)
    for _, f in ipairs(list) do
      local name = prefix .. f[1]
      if #name <= 19 then out[#out + 1] = wrap(f[2], ("  %-19s "):format(name), pad)
      else
        out[#out + 1] = "  " .. name
        out[#out + 1] = wrap(f[2], pad, pad)
      end
    end
  end
  field_lines(o.fields, o.prefix .. ".")
  for _, g in ipairs(o.groups or {}) do
    out[#out + 1] = ""
    out[#out + 1] = g.title
    field_lines(g.fields, g.prefix)
    if g.note then out[#out + 1] = wrap(g.note, "  ", "  ") end
  end
  out[#out + 1] = ""
  out[#out + 1] = ("Methods (%s:NAME(...); help(%s.NAME) explains one)"):format(o.prefix, o.prefix)
  local names = {}
  for name in pairs(o.methods) do names[#names + 1] = name end
  table.sort(names)
  for _, name in ipairs(names) do out[#out + 1] = wrap(o.methods[name], ("  %-19s "):format(name), pad) end
  return table.concat(out, "\n")
end

return M
