-- nz/session/help.lua - nz.help(): what the module offers, and one function explained.
--
-- Every public name of nz has one entry here (a test checks both directions),
-- so the list a user sees is the module as it is.
local M = {}

-- Sections in the order they are listed.
local sections = {
  { id = "jets", title = "Jets: truncated Taylor series with tangent (dual) directions" },
  { id = "functions", title = "Functions of numbers and jets (numbers give numbers)" },
  { id = "branches", title = "Branches that can be recorded (instead of a Lua if on a jet)" },
  { id = "mechanics", title = "Mechanical systems and their equations of any order" },
  { id = "scenes", title = "Scenes, effects and the classroom" },
  { id = "operators", title = "Operators on a function f(t, q, qd) (docs/theory.md §2, §5)" },
  { id = "session", title = "Session" },
}

local entries = {
  { name = "jet", section = "jets", usage = "nz.jet(t0, order [, d, D])  |  nz.jet{c0, c1, ...}",
    summary = "make a jet: the variable t0 + (t - t0), or one from its coefficients",
    text = [[
A jet is a truncated Taylor series in normalized coefficients c_0..c_K,
c_j = f^(j)(t0) / j!, optionally carrying D tangent (dual) directions, each
itself a series: the partial derivatives of the coefficients along that
direction.  Orders up to 1024 and up to 1024 directions are accepted.

  nz.jet(t0, K)          the variable t of order K at t0 (c = {t0, 1, 0, ...})
  nz.jet(t0, K, d, D)    the same, with tangent direction d of D seeded to 1
  nz.jet{c0, c1, ..., order = K, tangents = {{...}, ...}}
                         explicit coefficients (missing ones are zero)

Methods:  x:coef(j)  normalized coefficient c_j     x:deriv(j)  j! c_j
          x:order()  K       x:value()  c_0          x:coefs()   {c_0, ..., c_K}
          x:ntangents()      x:tangent(d)  the series of direction d as a jet
Operators + - * / ^ and unary minus mix jets and numbers in either order.
Comparisons < <= == compare values (c_0); note that Lua never calls == between
a jet and a number, so compare x:value() with a number.
A result combines operands of different orders at the lower order, and of
different tangent counts with the larger count (a missing direction is zero).
Outside a function's domain (log of a non-positive value, sqrt at 0 with
derivatives, division by a series with zero constant term) an error names the
function and the value: never a silent NaN or infinity.  A NaN or inf given to
nz.jet or nz.dual is refused, and one met in arithmetic names the argument
that carried it.  x:deriv(j) refuses an order whose coefficient has
underflowed (past about j = 170 for an O(1) function, where j! overflows):
scale time instead, the coefficients of nz.jet{t0, h, order = K} are
f^(j) h^j / j!.

Example:  t = nz.jet(0, 5); print(nz.exp(t))   --> jet{1, 1, 0.5, ...}]] },
  { name = "dual", section = "jets", usage = "nz.dual(v, d [, D])",
    summary = "the dual number v + eps_d (a jet of order 0 with D directions)",
    text = [[
Dual numbers are the jets of order 0.  nz.dual(2, 1, 3) is 2 + eps_1 with three
directions; f(x):tangent(1):value() is then df/dx at 2.]] },
  { name = "isjet", section = "jets", usage = "nz.isjet(v)", summary = "true if v is a jet" },
  { name = "exp", section = "functions", usage = "nz.exp(x)", summary = "exponential" },
  { name = "log", section = "functions", usage = "nz.log(x)", summary = "natural logarithm (x > 0)" },
  { name = "sqrt", section = "functions", usage = "nz.sqrt(x)",
    summary = "square root (x >= 0; x > 0 for a jet with derivatives)" },
  { name = "pow", section = "functions", usage = "nz.pow(x, y)",
    summary = "x^y: integer, real or jet exponent (same as the ^ operator)" },
  { name = "sin", section = "functions", usage = "nz.sin(x)", summary = "sine" },
  { name = "cos", section = "functions", usage = "nz.cos(x)", summary = "cosine" },
  { name = "tan", section = "functions", usage = "nz.tan(x)", summary = "tangent" },
  { name = "asin", section = "functions", usage = "nz.asin(x)", summary = "arc sine (|x| <= 1)" },
  { name = "acos", section = "functions", usage = "nz.acos(x)", summary = "arc cosine (|x| <= 1)" },
  { name = "atan", section = "functions", usage = "nz.atan(x)", summary = "arc tangent" },
  { name = "atan2", section = "functions", usage = "nz.atan2(y, x)",
    summary = "angle of the point (x, y), in (-pi, pi]" },
  { name = "sinh", section = "functions", usage = "nz.sinh(x)", summary = "hyperbolic sine" },
  { name = "cosh", section = "functions", usage = "nz.cosh(x)", summary = "hyperbolic cosine" },
  { name = "tanh", section = "functions", usage = "nz.tanh(x)", summary = "hyperbolic tangent" },
  { name = "abs", section = "functions", usage = "nz.abs(x)",
    summary = "absolute value (not differentiable at 0: see sign, smooth_abs)" },
  { name = "hypot", section = "functions", usage = "nz.hypot(x, y)",
    summary = "sqrt(x^2 + y^2) without overflow" },
  { name = "ifelse", section = "branches", usage = "nz.ifelse(c, a, b)",
    summary = "a where c is nonzero, else b: a branch that can be recorded",
    text = [[
A Lua `if q[1] > 0 then ... end` on a jet (or on the tracer that records a
function once as a graph) cannot be recorded: the function then falls back to
Lua evaluation.  Write the choice as a value instead:

  V = function(t, q)
    return nz.ifelse(nz.gt(q[1], 0), k1 * q[1]^2, k2 * q[1]^2)
  end

c is a number or a jet, usually from nz.lt, nz.le, nz.gt, nz.ge; it is true
when its value is nonzero (a Lua boolean is refused: x > 0 cannot be
recorded).  The chosen branch is returned whole, tangents included, in the
shape of a and b together (their lower order, their larger tangent count; a
number where both are numbers).  Both branches are computed, since they are
arguments: each must be defined where it is not chosen (clamp the argument of
a sqrt or log that is only meant for one side).  The derivative is that of
the branch taken; at the switch the function may jump or kink.]] },
  { name = "lt", section = "branches", usage = "nz.lt(a, b)",
    summary = "1 if a < b, else 0 (a number, or a constant jet)",
    text = [[
nz.lt, nz.le, nz.gt and nz.ge compare numbers and jets in any mix and return 1
or 0: a number for numbers, else a constant jet of the result shape (every
derivative and tangent 0), for nz.ifelse.  Jets are compared as the motion
goes on just after t0: by value first, and at a tie in value by the first
coefficient of the Taylor series in which they differ (c_1, then c_2, ...).
So nz.gt(t - t0, 0) is 1 at t0: the branch taken for t > t0.  Series equal in
every known coefficient are equal (a dual number knows only its value).
Tangents are not compared: a comparison is a step, its derivative is 0.
A recorded system decides alike: where its plans on doubles meet a tie in
value they hand the evaluation to the jets, and T, V and the constraints are
evaluated with the velocity in their series for every term of the
equations; Q is taken at the state, so a tie there is decided by value.]] },
  { name = "le", section = "branches", usage = "nz.le(a, b)", summary = "1 if a <= b, else 0 (see help(nz.lt))" },
  { name = "gt", section = "branches", usage = "nz.gt(a, b)", summary = "1 if a > b, else 0 (see help(nz.lt))" },
  { name = "ge", section = "branches", usage = "nz.ge(a, b)", summary = "1 if a >= b, else 0 (see help(nz.lt))" },
  { name = "max", section = "branches", usage = "nz.max(a, b)",
    summary = "the larger of a and b, whole: nz.ifelse(nz.ge(a, b), a, b)",
    text = [[
The operand that is larger by the rule of help(nz.lt), returned whole (value
and tangents), in the shape of both; a at a tie in every known coefficient.
Its derivative is the larger operand's, which at a crossing is the one that
is larger just after t0.  Numbers and jets mix as in arithmetic.]] },
  { name = "min", section = "branches", usage = "nz.min(a, b)",
    summary = "the smaller of a and b, whole: nz.ifelse(nz.le(a, b), a, b)" },
  { name = "clamp", section = "branches", usage = "nz.clamp(x, lo, hi)",
    summary = "lo where x < lo, hi where x > hi, else x (min(max(x, lo), hi), lo <= hi)" },
  { name = "sign", section = "branches", usage = "nz.sign(x)",
    summary = "-1, 0 or +1; every derivative 0 (a step, exact away from its jump)",
    text = [[
The sign of x by the rule of help(nz.lt): at x = 0 the sign of the first
nonzero Taylor coefficient, 0 for the zero series.  A step: all derivatives
and tangents of the result are 0, which is exact everywhere but at the jump.
nz.sign(x) * x is |x| on the side the motion takes, even at x = 0 where
nz.abs refuses a jet with derivatives; nz.smooth_abs(x, eps) is smooth there.]] },
  { name = "smooth_abs", section = "branches", usage = "nz.smooth_abs(x, eps)",
    summary = "sqrt(x^2 + eps^2) - eps: |x| within eps, smooth at 0 (slope x/sqrt(x^2 + eps^2))",
    text = [[
A smooth absolute value: below |x| by at most eps, x^2/(2 eps) near 0, its
derivative x/sqrt(x^2 + eps^2) continuous.  Use it where a force or an energy
with |x| must stay differentiable (an integrator with a Jacobian, a Taylor
series through x = 0).  Built from * + - and sqrt, so it is recorded with no
node of its own; eps may be a parameter (p.eps), a plain number must be > 0.]] },
  { name = "system", section = "mechanics", usage = "nz.system{coords = {...}, T = f, V = f, Q = f, ...}",
    summary = "define a mechanical system: help(nz.system) explains its fields and every method (listed below)",
    text = [[
Fields:
  coords   names of the k generalized coordinates, {"th1", "th2"}
  T        kinetic energy T(t, q, qd, params)           (q, qd: 1-based arrays)
  V        potential energy V(t, q, params)             (optional)
  Q        generalized non-potential forces Q(t, q, qd, params) -> {Q1, ..., Qk}
  L        a general Lagrangian L(t, q, qd, params), instead of or besides T
  bodies   particles and rigid bodies (see help(nz.bodies)): adds T, V, S
  S        acceleration energy along the motion (Wassmuth's form; from bodies)
  constraints  a list of functions Phi(t, q, qd, qdd, qddd, params) = 0 of any
           order: holonomic (of q only), first order (velocities, linear or
           not), second order (accelerations), third and higher; their order
           and linearity are found numerically (sys:constraints()).  Slots:
           the parameters after t are q, qd, qdd, ... and, from the 6th on,
           the last is params; q .. qddd are always given, so a constraint
           on q^(4) is function(t, q, qd, qdd, qddd, q4d, params)
  sample   a typical state {t =, q =, qd =, qdd =} near which constraints are
           classified (default: random states around 0, times spread over
           +-10); the states given to accel and simulate add samples near
           them the first time they are far from all others
  params   a table of named numbers passed to every function; change
           sys.params.m and the next call uses it (each call checks that
           they are still finite numbers, and names one that is not)
  name     a name for messages
  compile  false: run every function in Lua (default: record them in C)
  native   true: compile the recorded plans to machine code at first use,
           waiting for the compiler; false: never (default: in the
           background once a run has used a plan a little, switching to it
           when ready, or at once when cached; NZLUA_NATIVE; help(nz.cache))
T, V, Q and L may also be lists of functions whose contributions add up.
Functions receive jets (see help(nz.jet)): write them with nz.sin, nz.exp, ...
and plain arithmetic, and return a number or a jet.

Recording: when the system is made, each function runs once on traced
values and becomes an expression graph that the engine evaluates in C (M
and h are differentiated once on it).  A traced value answers as the jet it
stands for (type(x) is "userdata", nz.isjet(x) is true).  print(sys) shows,
one line each, which functions run in C and which stay in Lua, and why: a
Lua if or a comparison on the state (write nz.ifelse, nz.max, nz.min,
nz.clamp), math.* on the state (use nz.sin, ...), a jet method (x:coef(0)),
a non-number parameter or a default from params' __index, even when the
function's own pcall caught the error; or a recording that answers
otherwise than the function on jets (checked at two states, with what it
found: a type test, a table keyed by the state, a counter).  A function
that is not recorded is tried once on jets at the sample state, and one that
fails at every state (math.cos on a jet, q.th, returning nothing) is refused
there, at the nz.system line, with what to write instead.  Numbers in
params stay inputs however the function reads them (its argument, an
upvalue); a parameter it read while absent (p.c or 1) and that appears
later makes the system record again (print(sys) says so).  Other numbers
read from upvalues or globals are baked in when the system is made.
sys:graph_info() gives the graph's size, the recording time and what runs
as machine code; compile = false means do not record: everything runs in Lua.

Methods (t a number, q, qd, qdd tables of k numbers); help(sys.NAME) shows
one, e.g. help(sys.simulate):
  sys:residual(n, t, q, qd, qdd [, lambda] [, form | {form =, higher =}])
        k residuals of order n,
        (1/n)(dT^(n)/dq^(n) - (n+1) dT/dq) - Q (docs/theory.md (3.1)),
        n = 1..100; form: "generalized" (default), "lagrange", "difference"
        (3.2), "euler" (3.3), "appell" (4.2), "extremal" (4.3), "wassmuth"
        (particles, n >= 2).  "extremal" is dK_n/dq^(n), the equations only
        when Q does not depend on q^(n): with forces that depend on q', at
        n = 1 it differs by sum_j q'_j dQ_j/dq'_i (sys:rule{extremal = true}
        picks an n where it holds).  Or {form = ..., higher = {q3, ...}}:
        derivatives beyond qdd (default 0; the equations do not depend on
        them).  With multipliers lambda the terms -A^T lambda of (6.2) are
        included.  n = nil: the rule's n.
  sys:accel(t, q, qd [, opts]) accelerations qdd, multipliers lambda and, with
        constraints, a report {iterations, residual, rcond, start}.  Without
        constraints: Cholesky of M.  With constraints closed at the acceleration
        level: one SVD solve of [M -A^T; A 0]; second-order constraints
        nonlinear in qdd: GSL's hybridsj (Newton with a trust region) from the
        unconstrained accelerations or opts = {qdd = guess, lambda = guess}.
        Every solution is checked: the residual of (6.2) and of the
        constraints (evaluated again at it) as a normwise backward error of
        the equilibrated system, to 1e-10 (report.backward_error); the bound
        on its error, max(backward error, eps) / rcond, to 1e-6
        (report.error_bound: near a rank loss of the constraints' gradients
        the motion is not determined); each constraint's order.  Where it
        fails the constraint is classified again at this state and solved
        again (report.reclassified counts them), else an error names the
        constraint, the state and the violation.  report.violation: how far
        (q, qd) is from the constraints of order <= 1; off them by over 1e-8
        of their terms, a warning once per system.  opts.check = false skips
        both (to measure their cost).  Singular systems name the
        constraints involved.  opts.out = a table: qdd is written into it
        (entries 1..k) and returned, and without constraints lambda is one
        shared empty table: a loop that passes the same opts makes no table
        per call.  opts: qdd, lambda, tol, maxit, rcond_min, check, out; any
        other key is an error.  Every method checks its arguments
        (t, q, qd: k finite numbers each) and names the one that is wrong; a
        method called with a dot (sys.accel(...)) says to write a colon.
  sys:constraints([{quiet = true}])  the classification, one entry per
                             constraint: order, linear in the top
                             derivative, holonomic, homogeneous in qd
                             (Euler's theorem), evidence; it prints as a
                             table (print(sys:constraints()) in a script;
                             the session prints it once); it prints nothing
                             itself, so quiet changes nothing
  sys:rule([{extremal = true}])  Dolapchiev's n and a paragraph saying why
  sys:reduced(t, q, qd [, n] [, form])  accelerations from Tsenov's reduced
                             equations (7.1); order >= 3: q^(p) from the
                             level-p equations, form = {qdd =, q3d =, ...,
                             lambdas = {lambda, lambda', ...}}
  sys:project(t, q, qd [, {tol =, maxit =, qdd =, q3d =, ..., lambda =,
        lambdas =}])         the nearest state on the constraints of order
                             <= 1 (to tol, 1e-12, in at most maxit = 50
                             Newton steps); with constraints of order p >= 3
                             also the start's higher levels: qdd, q3d, ...
                             (0 if absent) change least (a consistent one
                             not at all) and come back as report.qdd,
                             report.q3d, ...; the multipliers (report.lambda,
                             report.lambdas = {lambda, lambda', ...}) are
                             what the levels need, unless given as lambda or
                             lambdas: then they change least with the levels
  sys:check_state(t, q, qd [, tol])  error if a constraint is violated by more
                             than tol (1e-8) of the size of its terms
  sys:reaction_power(t, q, qd)   R_0 of (9.1): the power of moving constraints
  sys:mass(t, q [, qd]), sys:bias(t, q, qd), sys:mass_bias(t, q, qd)
                             M and h of M qdd + h = 0 (h includes -Q + dV/dq)
  sys:energy(t, q, qd)       T + V (nil with L only), H = sum qd dL/dqd - L,
                             and whether H is a first integral: {holds,
                             reasons, ...}
  sys:equations(n, t, q, qd [, qdd] [, {quiet = true}])  print the terms of
                             (3.1) per coordinate and the residual at qdd
                             (e.g. measured accelerations).  Without qdd the
                             system's own accelerations are used: the last
                             column is then the rounding of that solve in
                             the form of order n (the forms agree), not a
                             check of a motion.  quiet: return the text and
                             the residuals instead
  sys:residuals_of{t = {...}, q = {{...}, ...} [, qd = {{...}, ...}] [, n =]
        [, quiet = true]} or {csv = "file.csv"}  the defect of points that
        did not come from nzlua (your integrator, a measurement), as
        tr:residuals gives it: positions alone (curve through q at 8 points,
        floor ~dt^6 and ~eps/dt^2) or with velocities.  csv: a header with t
        and each coordinate (and name' for each velocity), as tr:csv writes.
        t must increase; at least 8 points.  An integrator of order p shows
        its defect falling by 2^p when its step is halved
  sys:graph_info()           the recording's figures: nodes, record_seconds,
                             mass_bias_nodes, functions recorded (also
                             .compiled, its old name)
                             and interpreted, native_plans, native_series,
                             native_compiling (in the background),
                             native_seconds (compiling took), native_waited
                             (runs waited), native_why (why no machine code)
  sys:simulate{q0 =, qd0 =, t1 = [, t0, dt, method, rtol, atol, step, h0,
        order, events, event_tol, project, baumgarte, monitors, progress,
        check, dense]}  a trajectory (help(tr.NAME): its methods).
        Defaults: t0 = 0; qd0 at rest; dt = (t1 - t0)/200 (the output grid);
        method = "rk8pd"; rtol = 1e-10, atol = 1e-12; step none (adaptive;
        step = h: fixed steps of at most h); h0 = min(dt, 1e-3) (the first
        step); events none (a list of {name =, f = function(t, q, qd) ... end,
        direction = 0 | 1 | -1, stop = false}); event_tol = 1e-12;
        project = false (true: back onto the constraints when they drift past
        1e-10); baumgarte = nil ({alpha =, beta =}); monitors none ({energy =
        true, work = true}); progress on a terminal only; check = true (the
        start must satisfy the constraints); dense = true.
        Each option is checked (which, what it got, what it accepts; the
        output points must fit in 1 GB,
        require('nz.motion.simulate').MAX_MEMORY); a fixed step with rtol,
        atol or h0 warns once that they do nothing; a run
        that will take over a minute or 1e7 steps at the pace of its last
        steps says so once (with a larger dt or step when the grid or fixed
        steps set the count; bsimp or msbdf only when its steps times the
        Jacobian's spectral radius sit at the method's stability boundary)
        and goes on (tr.stats.long_run); one whose steps stop advancing t
        stops with the state and M.  Steps that collapse against a jump of
        the right-hand side stop the run with the branch that decides it (a
        comparison, sign, ifelse or atan2's cut at rounding level or at the
        switch), its function, the time and the state.
        Event functions are recorded and watched in C; one that cannot be
        recorded is called in Lua (tr.stats.events_why says why).  The
        events of a step are located and handed over in time order.
        Unilateral contacts (help(nz.unilateral)): the run stops at nothing;
        impacts, contacts opening and closing, stick and slip are its events
        (tr.events), the motion goes on from each; not with project,
        baumgarte or the work monitor.
        dense (true by default): a GSL stepper's output points inside a step
        come off the step's Hermite interpolant (q, qd, qdd at its ends and
        the one or two steps before), so a fine dt adds no step; an error
        control checks each point against atol + rtol |y| and makes a point
        that misses it a step end (the step taken again): every point meets
        the run's tolerance.  Events are located on the interpolant too.
        dense = false: every output point is a step end (the grid caps the
        steps).  The grid still limits a run with dense = false, with a fixed
        step, with msadams and msbdf (off unless dense = true: a point made a
        step end restarts them); tr.stats.grid_why says
        so when it set the steps; tr.stats.interpolated, forced: the points
        read off an interpolant, and those its control made step ends.
        method: a GSL stepper (nz.methods; rk8pd by default) or "taylor":
        Taylor's method on the recorded series of the motion, for a system
        whose T, V, Q and constraints are recorded and do not branch on the
        state, free or with constraints of order 0, 1, 2 (their series kept
        at 0 to the method's order, nothing projected: tr.violation shows
        the drift); order ceil(-ln(tol)/2 + 1) (18 at 1e-14) and steps from
        rtol/atol, no rejected step; the output grid is read off each step's
        polynomial, so a fine dt costs no extra step (tr.stats.order: the
        order used); events are located on each step's polynomial (no
        integration again; their functions must be recordable).  Not with
        taylor: constraints of order 3 or more, project and baumgarte, the
        work monitor, step and h0 (each refused with the method to take).
        method = "variational", step = h [, order = 2 | 4 | 6 | 8]: a
        variational integrator built from the Lagrangian L = T - V (Marsden
        and West): the discrete action of the trapezoidal rule made
        stationary, step by step, so that the energy stays within a bound
        for all time (no drift) and the momentum of every symmetry of L (the
        angular momentum of a central force, the momentum of a cyclic
        coordinate) is kept to rounding.  A constant mass matrix with
        forces that do not depend on qd (particles, Cartesian coordinates):
        Stormer-Verlet, explicit, one evaluation of qdd a step; any other L:
        the discrete Euler-Lagrange equations by Newton with the exact
        Jacobian from the jets.  Forces Q by the discrete Lagrange-
        d'Alembert principle; holonomic constraints (on q and t) held to
        rounding at every step (RATTLE).  order = 4, 6, 8: symmetric
        compositions of the order-2 step (Suzuki's 5 steps; Kahan and Li's
        9 and 17), each as conservative.  Output velocities from the
        discrete Legendre transform; events located as for rk4.  step is
        required (equal steps, at most h, landing on each output time);
        not with rtol, atol, h0, constraints on qd or qdd (nonholonomic),
        contacts, project, baumgarte or the work monitor (each refused with
        the reason).  order applies to this method only.
  sys:simulate{..., qdd0 =, q3d0 = ..., guess =}  constraints of order
                             p >= 3 (linear in their top derivative): the
                             state is q, qd,
                             .., q^(p-1) and lambda, .., lambda^(p-3); (6.2)
                             differentiated p-2 times gives q^(p) and
                             lambda^(p-2).  The start levels are required and
                             checked.  Nonlinear in q^(p): the state is q ..
                             q^(p-1), and (q^(p), lambda) solve (6.2) with the
                             constraints by Newton at each time (needs
                             lambda ~= 0); guess = {lambda =, q3d =} picks the
                             first root, tr.branch tells it, tr.top[i] =
                             q^(p).  Implicit methods: Jacobian by central
                             differences; project = true also projects qdd ..
                             and lambda ..
  sys:linearize{q =, qd = [, t, coords, speeds, hold, dependent]}  the motion
                             linearized about an equilibrium or a steady
                             motion, with or without constraints (order 0, 1,
                             2): lin.state (names), lin.A (x' = A x, exact:
                             jets, not finite differences), lin.M, lin.C, lin.K
                             when the kept speeds are the kept coordinates' (M
                             the reduced mass matrix on the constraints),
                             lin.residual (the kept accelerations there: 0 at a
                             steady point), lin:eigenvalues() ({re, im}),
                             lin:modes(), print(lin) (frequency, damping,
                             stable or not, the mode's shape).
                             coords/speeds: names or numbers kept in the state
                             (default: every coordinate the constraints leave
                             free, less those that do not appear, and their
                             speeds).  A coordinate left out is dependent
                             (solved from the holonomic constraints by Newton:
                             lin.dependent, lin.position_newton) or ignorable
                             (it must not appear: said if it does); a speed
                             left out is dependent (solved from the velocity
                             constraints: lin.dependent_speeds), held (hold: a
                             motor, a wheel's rate in a steady run) or must not
                             appear.  nzlua picks the dependent ones by complete
                             pivoting on the constraints' gradients unless
                             named (dependent = {...}), and print(lin) says
                             which.  lin.q, lin.qd: the point, solved.
                             help(lin): every field.
  sys:eigen_sweep{values = {...}, at = function(v) return {linearize options}
                  end [, parameter = "v", tol]}  the eigenvalues against a
                             parameter (at may also set sys.params): sw.rows
                             ({value, eigenvalues, status}: stable, neutral or
                             unstable), sw.crossings ({value, from, to, kind,
                             frequency}: where stability changes, located to
                             tol, default 1e-10 of the span: Brent's method
                             where the largest real part changes sign,
                             bisection where modes meet on the imaginary
                             axis), print(sw), sw:csv([file]) (without a
                             file: the CSV text), sw:plot{[file =, title =,
                             width =, height =, quiet =]} (real and
                             imaginary parts against the parameter; quiet =
                             true returns the terminal's plot as text
                             instead of printing it).  help(sw): the fields.
  sys:show{[n = 3, tex = true, lua = true, mass = true, bias = true,
            reduced = true, appell = true, names = true, width = 100]}
                             the equations as formulas read from the recorded
                             graphs: per coordinate M(q) q'' + h(q, q') =
                             A^T lambda (the equations of every order n
                             collected), the constraints, M and h on request,
                             Tsenov's reduced equations without multipliers
                             (reduced = true, one or two constraints), Appell's
                             S up to terms free of q'' (appell = true);
                             like terms collected, parameters (sys.params)
                             shown by name, repeated parts named when the
                             text runs over 3 lines of width characters
                             (where c1 = cos(th1 - th2); names = true always,
                             false never); tex = true: a LaTeX
                             aligned block; lua = true: a Lua chunk returning
                             function(t, q, qd, qdd, lambda, params, higher)
                             -> residuals (higher = {q''', ...}).
                             n = N: Dolapchiev's equations of order N, (1/N)
                             (dT^(N)/dq^(N) - (N + 1) dT/dq) = Q + A^T lambda
                             (N = 1 Nielsen's, 2 Tsenov's), derived from
                             T^(N) on the graph: the equations collected, then
                             the terms dT^(N)/dq^(N), dT/dq, Q (-dV/dq in it)
                             per coordinate. T^(N) reads q to q^(N+1), but
                             dT^(N)/dq^(N) = N d/dt dT/dq' + dT/dq (2.1): no
                             derivative above q'' is left, and every N
                             collects to the same equations. With appell =
                             true: R_N = (1/N)(T^(N) - (N + 1) T_0^(N)) (T_0: T
                             with its velocities held), up to terms free of
                             q^(N) (whole for N = 1, held velocities written
                             th'_0); lua, mass, bias, reduced, tex as above
  sys:export{lang = "c" | "python" | "octave", file = "name.c"
             [, jacobian = false, smooth = true, main = {q0 =, qd0 =,
             t1 =, dt = [, t0, rtol, atol]}]}
                             the equations as code that runs without nzlua:
                             nzx_accel (q'' and lambda: the saddle-point
                             system by an included LU), nzx_rhs (f = (q', q'')),
                             nzx_jacobian (exact), nzx_constraints; main
                             integrates (C: GSL rk8pd, cc -O2 f.c -lgsl
                             -lgslcblas -lm; Python: NumPy; Octave: ode45) and
                             prints CSV "t,<coords>,<coords>'" every dt.
                             Constraints of order 0, 1 and 2 are exported (one
                             of order 2 must be linear in q''); the others,
                             and functions that run in Lua, are refused with
                             the reason.  A system with unilateral contacts is
                             refused (the code has no events or impacts);
                             smooth = true writes it without its contacts and
                             says so on the file's first line
  sys:energy_integral()      whether H = T2 - T0 + V is a first integral and why
                             (L free of t, constraints homogeneous in the
                             velocities, no force doing work), checked at
                             sample states; print it for the statement
  sys:energy_theorem(tr)     along a trajectory simulated with monitors =
                             {energy = true, work = true}: the drift of H and
                             of T + V - W, W = integral (R_0 + Q.q') dt: the
                             work of moving constraints and forces Q
                             (Rumyantsev eq. 3.3-3.7)
  sys:parametric{[time = "t", tau = function(s) return t end]}  the system in
                             (q, t) with a parameter as its time and
                             Lambda = L(t, q, x'/t') t' (eq. 1.14-1.17): k + 1
                             equations, the last the energy equation; tau fixes
                             t = tau(s), so that it can be integrated
  sys:jacobi_whittaker{h =, independent = "phi"}  with H = h conserved, the
                             path as a system in "time" phi (eq. 2.8-2.12):
                             R = 2 sqrt((h + L0) G) + T1, constraints kept;
                             path:simulate{t0 = phi0, t1 = phi1, ...} gives
                             the other coordinates against phi, and
                             path:elapsed(tr) the physical time at each point
                             (dt/dphi = sqrt(G / (h + L0)), integrated with
                             the path by tr's method and tolerances: as
                             accurate as the path on any output grid)
  sys:equilibrium{q = guess [, qd, t, coords, hold, dependent, tol, maxit]}
                             an equilibrium or a steady motion near the guess:
                             Newton on the kept accelerations in the kept
                             coordinates, the dependent coordinates and speeds
                             solved at every step, the other speeds held as
                             given; returns q and {iterations, residual, qd}
  sys:report{q = [, qd, t, orders = {n, n + 1}, extremal = true, simulate =
             {...} | false, plot = {...} | false]}  a classroom summary:
                             the system, the rule, residuals of two orders at
                             the state's solved accelerations (the forms
                             agree), a short integration with the defect of
                             its motion (tr:residuals) and a plot;
                             returns the trajectory and the rule's n (the
                             session does not print them again)
The trajectory tr = sys:simulate{...}: tr.t[i], tr.q[i][j], tr.qd[i][j],
tr.qdd[i][j], tr.lambda[i][r], tr.events[e] (.name, .t, .q, .qd), tr.status,
tr.stats, tr.violation, monitors; help(tr) lists every field and statistic;
with contacts tr.events[i] also holds kind = "impact" | "closes" | "opens" |
"sticks" | "slips", qd_after, impulse, energy_lost, ...; tr.contacts (modes,
Zeno) and the columns "N.name", "T.name" (the contact forces);
help(tr.NAME) shows one method, e.g. help(tr.plot):
  tr:column(name)            the values of a quantity along the motion: a
                             coordinate, "name'" (velocity), "name''", "t",
                             "E" (T + V), "H", "work", "violation", "lambda1"
  tr:plot{[y = {...}, x = "t", phase = "th", file = "f.svg" | "f.png", title,
           xlabel, ylabel, legend = false, width =, height =, size = {w, h},
           drift, quiet = true]}  a plot in
                             the terminal (sized to it) or to a file; width
                             and height (or size = {width, height}) in
                             characters in the terminal, pixels in a file;
                             quiet = true returns the terminal's plot as text
                             instead of printing it; E and H
                             are drawn as their drift from the first value;
                             unknown options and wrong values are refused.
                             In the terminal the ticks follow the width (the
                             labels apart and distinct) and a point on the
                             edge of the data is drawn inside the frame.
                             In a notebook (Jupyter): an inline SVG, its
                             size in characters as for the terminal (8 x 16
                             pixels each); tr:section, sw:plot and the
                             work-precision diagram too
  tr:csv([file])             CSV with a header naming every column (t, q,
                             q', q'', q''' and above where the run holds
                             them, the multipliers, the monitors): to the
                             file (written beside it and renamed: never half
                             a file; returns its name), or without a file
                             the CSV text (the session shows it; a script
                             can io.write it)
  tr:residuals([n] [, {quiet = true}])  the defect of the motion: the
                             equations of order n on the curve through the
                             points (q and q' each through 8 points, degree
                             7: no right-hand side enters), at 2 points in
                             each interval; 0 only on an exact motion, it is
                             the error made per unit time (~h^p for steps h
                             of order p, ~rtol when adaptive), not the error
                             accumulated.  Per equation {coordinate, max,
                             t_max, rms, floor}; .kinematic: q' - dq/dt per
                             coordinate; .constraints: Phi per constraint
                             (multipliers by least squares at each point);
                             .t, .dynamic, .phi: the values at each sample.
                             floor: what the curve adds (~dt^7, rounding
                             ~eps/dt); a defect near it is set by dt.  It
                             prints as its table (printed unless quiet; the
                             session shows it once)
  tr:consistency([n] [, {quiet = true}])  the forms of order n at the run's
                             own q'' and multipliers, max and RMS per
                             equation: rounding by construction (the solver
                             took q'' from the equations at the same
                             points); it checks that the forms agree, not
                             the motion
  tr:section{[when = "event name", plot = {"y", "y'"}, draw = false, file =,
              title =, width =, height =]}
                             a Poincare section: the two quantities at each
                             crossing of the event (simulate with events =
                             {{name =, f =, direction = 1}}), as {x, y, t}
                             and drawn (sizes in characters in the terminal,
                             pixels in a file)
  tr:animate{[file = "m.gif" | "m.svg", frames = 60, fps = 20, draw = f,
              plane = "xy", links = true, range = {x0, x1, y0, y1},
              title =, width =, height =, view = "2d" | "3d"]}
                             the mechanism frame by frame: in the terminal,
                             as an animated GIF, or SVG frames; from the
                             bodies (a point each, linked as a chain from a
                             fixed pivot at the origin, drawn # in the
                             terminal and a filled square in a file) or
                             draw(t, q) -> {points = {{x, y}}, segments =
                             {{x1, y1, x2, y2}}, pivots = {{x, y}}}; frames
                             a whole number >= 1, fps in (0, 100], plane
                             "xy", "xz" or "yz" (bodies only), links true or
                             false (false: no links, no pivot), range four
                             numbers: checked before drawing.  In a
                             notebook: an inline animated GIF.  view =
                             "3d": the bodies in space (a particle a
                             sphere, a rigid body its ellipsoid of inertia
                             and axes, the links, the contacts' points, a
                             grid across gravity): in a notebook a three.js
                             scene to turn, play/pause and a time slider;
                             in the terminal and to a file the same seen
                             from a fixed direction
  print(tr)                  a summary: cost, status, drift, monitors
  print(sys)                 a summary]] },
  { name = "forms", section = "mechanics", usage = "nz.forms",
    summary = "the names of the forms of the equations sys:residual accepts" },
  { name = "bodies", section = "mechanics", usage = "nz.bodies{ {mass =, pos = [, rot =, inertia =]}, gravity = }",
    summary = "T, V and S of particles and rigid bodies from their positions",
    text = [[
Each body: mass (a positive number), pos = function(t, q, params) returning its
centre of mass {x, y, z}; a rigid body also has rot = function(t, q, params)
returning its 3x3 rotation matrix (body axes to space) and inertia =
{I1, I2, I3} (principal, about the centre of mass) or a symmetric 3x3 matrix,
in body axes.  gravity = {gx, gy, gz} adds V = -sum m g.r.  The mass, the
inertia and the gravity may each be a function of the params instead:
mass = function(p) return p.m end, gravity = function(p) return {0, -p.g, 0}
end; the equations then keep the symbols (sys:show prints m and g) and
follow sys.params.  Velocities come from the jets.  Returns {T = ..., V =
..., S = ...} (S, for Wassmuth's form, for particles only); nz.system{coords
= ..., bodies = {...}} does the same inline.]] },
  { name = "unilateral", section = "mechanics",
    usage = "nz.unilateral(gap [, {e =, mu =, mu_s =, slip =, name =, at =}])",
    summary = "a unilateral constraint gap(t, q) >= 0: contact, impacts, friction",
    text = [[
An entry of a system's constraints: gap(t, q, params) >= 0, a distance (its
multiplier is then the contact force).  While it touches and pushes
(lambda >= 0) it is held as a holonomic constraint; it opens where lambda
reaches 0, and closes where the gap reaches 0, with an impact when it
approaches: Lagrange's impulse equations M (q'+ - q'-) = J^T P with Newton's
law J q'+ = -e J q'- (e in [0, 1], 0 by default: it stays closed), every
touching contact at once (an LCP, Lemke's algorithm): Newton's cradle of
three touching balls hit at v leaves with (-1/3, 2/3, 2/3) v, where a real
cradle's quick sequence of binary impacts gives (0, 0, v); a small gap
between the balls (1 mm) gives that sequence and that outcome.  Coulomb
friction: mu (sliding), mu_s >= mu (sticking), slip = function(t, q, qd,
params), the slip velocity (or a function of (t, q) whose rate it is), or
slip = {f1, f2}: the two slip velocities along orthonormal tangent
directions, the isotropic cone |F_t| <= mu lambda with the friction against
the slip in any direction (a puck on ice); it sticks where the slip velocity
reaches 0 and the force to hold is within mu_s lambda, and slides again where
it leaves that cone.  Contacts that depend on each other (a block on two
corners with friction at both, a table on four legs) are held together: the
motion is unique, their forces are the least-norm ones that are admissible
(m g/2 per corner, m g/4 per leg).  Painleve's paradox is an error naming the
contact.  Impacts accumulating in finite time (Zeno), or rebounds below what
the run resolves, end in persistent contact: tr.contacts.zeno[i] has
.accumulation, the time the impacts predicted (a bouncing ball's t1 (1 +
e)/(1 - e)), .t, the last impact's, made plastic, from which the contact is
held, and .contact, its name.  at = function(t, q, params) -> {x, y, z}: the
point tr:animate draws while it is held.  Every method runs it (the GSL
steppers and taylor; events on their dense output; taylor cannot start an
isotropic cone sliding from rest).  tr.events lists each contact's impulse
at an impact, and each closing, opening, stick and slip; tr.contacts the
modes; sys:show{} writes the contacts' forces and laws; sys:accel and the
other methods see the system without its contacts.  nz.effects.contact and
friction declare the same in a scene.  docs/theory.md §13.]] },
  { name = "scene", section = "scenes",
    usage = "nz.scene{coords =, bodies = {{name =, mass =, pos = ...}}, effects = {...}}",
    summary = "a system built from bodies and the effects the scene declares",
    text = [[
A scene is a system assembled from named bodies ({name =, mass =, pos =
[, rot =, inertia =]}: T comes from them) and the effects it declares
(help(nz.effects)).  Only what is declared is built, so only that is ever
computed: an effect that a scene does not name costs nothing (make bench:
bench/scene_cost.lua).  It also takes T, V, Q, L, constraints, params and
sample as nz.system does, and returns a system (print(sys) lists its
effects).]] },
  { name = "effects", section = "scenes", usage = "nz.effects.NAME{...}",
    summary = "gravity, spring, damper, force, driven, knife_edge, rolling_disk, rolling_ball, constant_speed, constraint, contact, friction",
    text = [[
Points are body names, functions (t, q, params) -> {x, y, z} (moving
supports) or fixed {x, y, z}; coordinates are given by name.  g, k,
length, rest, cubic, c, radius and speed may be functions of the params
(k = function(p) return p.k end: sys:show keeps the symbol); e, mu and mu_s
are numbers.  A wrong or missing parameter is an error naming the effect
and the parameter.
help(nz.effects.NAME) explains one, with its parameters.
  gravity{g = {0, 0, -9.81}, bodies = {names}}     V = -sum m g . r
  spring{between = {A, B}, k =, length =, cubic =, energy = f(s)}  or
  spring{coordinate = "x", k =, rest =, cubic =}   V = k s^2/2 + cubic s^4/4
  damper{between = {A, B}, c =} or {coordinate =, c =}   Rayleigh: D = c s'^2/2
  force{f = function(t, q, qd) return {Q...} end}  generalized forces, or
  force{at = point, F = function(t, q, qd) return {Fx, Fy, Fz} end}
  driven{coordinate =, motion = function(t)}       q = motion(t), rheonomic
  knife_edge{x =, y =, heading =}                   no sideways velocity
  rolling_disk{x =, y =, heading =, angle =, radius =}
  rolling_ball{body =, radius =}                    a body with rot on the plane
  constant_speed{coords = {...}, speed =}           nonlinear, first order
  constraint{f = function(t, q, qd, qdd) ... end}   any other constraint
  contact{name =, gap = function(t, q) ... end, e =}  gap >= 0 (or at = point
         with plane = {point =, normal =} or sphere = {center =, radius =})
  friction{contact = name, mu =, mu_s =, slip = function(t, q, qd) ... end}
         Coulomb at that contact (or tangent = {x, y, z} along its plane)]] },
  { name = "rotations", section = "scenes", usage = "nz.rotations.euler_zxz(psi, theta, phi)",
    summary = "rotation matrices x(a), y(a), z(a), mul(A, B), euler_zxz for a body's rot" },
  { name = "print", section = "session", usage = "nz.print(v, ...)",
    summary = "print values as the session shows them (numbers in their shortest exact form, tables readable; in a notebook with their tables as HTML)" },
  { name = "format", section = "session", usage = "nz.format(v)",
    summary = "a value as the session shows it, as a string" },
  { name = "check", section = "scenes", usage = "nz.check(sys, function(t, q, qd, qdd) return {...} end [, {states =, tol =, seed =, quiet =}])",
    summary = "check a derivation by hand: equivalent to the system's equations?",
    text = [[
Your function returns k expressions meant to vanish on the motion.  At 10 random
admissible states (projected onto the constraints) nz.check tests that each
expression vanishes at the true accelerations and that together they determine
them (full rank in qdd, by dual numbers), so a recombination or scaling of the
rows is accepted.  It says which equation is wrong, where, with the true
accelerations and the value your equation gives.  Prints the verdict and
returns ok, text (typed at the prompt, the verdict shows once); options
{states = 10, tol = 1e-8, seed = 4711, quiet = true (print nothing)}.  Write
the equations with nz.sin etc.]] },
  { name = "longrun", section = "mechanics",
    usage = "nz.longrun(sys, {q0 =, qd0 =, t0 =, t1 =, methods =, tol =, period =, from =, samples =, integrals =, "
      .. "plot =, quiet =, simulate =})",
    summary = "what accuracy costs over time: the error of the first integrals against time, its growth, the cost",
    text = [[
Runs the same motion over a long span once with each method and watches
its first integrals: the energy T + V (integrals = {energy = false} leaves
it out) and any given as integrals = {name = function(t, q, qd) return
value end} (an angular momentum, say).  Each one's error |I(t) - I(t0)|
(relative to |I(t0)| where that is not 0), at samples = 1000 output points,
goes into a table with its growth: the exponent of a least-squares fit on
log-log axes of its RMS over windows of a factor sqrt(10) in time, from
`from` on (10 periods, or 10 samples), with the processor time of the run,
per period when period = P is given (and the time axis in periods).  What
the exponent says: about 1, a drift (a step whose error has a sign: rk4,
rk8pd); 0.5, Brouwer's law (the rounding's random walk alone: taylor at
rtol = atol = 1e-15); 0, bounded (method = "variational": its energy
oscillates, the momentum of a symmetry is kept to rounding).
methods: names as nz.workprecision takes them, run at tol (1e-10: rtol =
tol, atol = tol / 100; variational, variational4, ..., at step =
tol^(1/order)), or tables of simulate's options {method = "variational",
step = P/400, order = 4, name = "verlet"}; the default rk8pd, taylor and
variational.  A warm-up run per method over a hundredth of the span builds
and compiles its plans first (not timed; one evaluator for the study, as
nz.workprecision).  plot = true draws the errors against time (log-log, a
line per method and integral, each point the largest error of its bin) in
the terminal, plot = "file.svg" (or .png) to a file, a notebook inline;
quiet = true prints nothing; simulate = {...} adds options to every run (not
method, rtol, atol, step, order, dt).  Returns the rows {method, integral,
error (RMS over the last window), final (at t1), exponent, windows, seconds,
per_unit, steps, nfev, status}, which print as the table; a method that
fails has its rows marked failed with the message.]] },
  { name = "workprecision", section = "mechanics",
    usage = "nz.workprecision(sys, {q0 =, qd0 =, t0 =, t1 =, dt =, methods =, tols =, reference =, reference_method =, "
      .. "reference_tol =, budget =, x =, plot =, quiet =, simulate =})",
    summary = "what accuracy costs in time: error, time, evaluations per method and tolerance",
    text = [[
Runs the same motion with each method at each tolerance (rtol = tol,
atol = tol/100), measures the error (max over the output grid of
|q - q_ref|) against reference = function(t) return {q1, ...} end when the
scene has a closed form, or else against a run of reference_method (rk8pd)
at rtol = atol = reference_tol (1e-13), and prints a
table of error, time, right-hand-side evaluations and steps.
How the time is measured: first, not timed, the reference run and one
warm-up run per method, which build the plans the method uses and compile
them to machine code (the study compiles every plan at its first use, as
native = true does, then restores the system's setting; a system made with
native = false runs interpreted throughout); the table says how long that
took and the title which evaluator ran.  Then each point runs at least 3
times and until it has spent budget = 0.2 seconds, the next run always the
point that has spent least (each point's runs spread over the study).  A
run's time is its processor time (os.clock: other programs on the machine
add none); a point's time is the minimum of its runs (the machine only adds
noise, so the minimum is the method's own cost), with the median and the
maximum beside it.  "!" marks a row whose error is larger than at a looser
tolerance of the same method (the error does not follow the tolerance
there); the diagram draws those apart.  "(grid)" marks the rows whose steps
the output grid set (tr.stats.grid_why: msadams and msbdf, and any run with
dense = false, stop at every output time, and a run whose interpolant missed
the tolerance at many points made them step ends; a larger dt shows the
method's own cost; taylor reads its points off the series).  plot = true
draws the work-precision diagram (log-log, error against the minimum time, a
line per method) in the terminal; plot = "file.svg" (or .png) writes it;
x = "nfev" or "steps" puts the right-hand-side evaluations or the steps on
its x axis instead of the time (taylor is left out of "nfev": its
evaluations are series).  quiet = true prints no table; simulate = {...}
adds options to every run (not method, rtol, atol).  Returns the rows
{method, tol, error, time, time_median, time_max, runs, wall (the least
wall time of the stepping alone), nfev, steps, status, flag}, which print
as the table (typed at the prompt: the table once); rows.study says how
they were measured.  A bad option (an unknown
method, a tolerance <= 0, ...) is one error naming it.
Defaults: methods rk4, rkf45, rkck, rk8pd, rk4imp, bsimp, msadams, msbdf,
taylor (taylor runs free and constrained recorded systems; it is skipped, with
the reason, for constraints of order 3 or more, a system that is not
recorded, the work monitor, or whatever else it cannot run); methods may also
name variational, variational4, variational6, variational8 (method =
"variational" of order 2, 4, 6, 8: fixed steps, run at step = tol^(1/order)
so that their errors span the same decades; skipped, with the reason, where
they do not apply);
tols 1e-4, 1e-6, 1e-8, 1e-10; dt as simulate's (the output grid the error is
measured on: with dense output it adds no steps).  The table ends with the
cheapest method for each accuracy, and the methods within the noise of it
(the slower one's fastest run no slower than the faster one's median, or
the two within 20 %); the diagram labels each point with its tolerance and
gives each method its own mark (A, B, C ... in the terminal, shown in the
key; there a tolerance label is written only where it covers nothing and
stays inside the frame: the table gives every tolerance).
Ctrl-C stops the study, keeps the rows done and marks the interrupted one
("stopped by Ctrl-C", once).]] },
  { name = "sweep", section = "mechanics",
    usage = "nz.sweep{system = sys | file =, grid = | list = | sample =, run = function(sys, point), jobs =, out =, "
      .. "resume =, retry =, progress =, todo =, from =, parallel =, worker =}",
    summary = "a system at many points on every core: one row per point, appended to a CSV as each finishes",
    text = [[
Points: grid = {amp = {0.5, 1, 1.5}, l = {1, 2}} (every combination, the first
name in alphabetical order varying slowest), list = {{amp = 0.5, l = 1}, ...}
(every point with the same names), or sample = {n = 100, seed = 1, ranges =
{amp = {0, 1.5}}} (uniform, splitmix64: the same points on every machine).
Values are numbers or strings.  For each point the names that are in
sys.params are set (and restored afterwards), then run(sys, point) returns a
table of outputs {name = number | string | boolean, ...}.
  file = "scene.lua"   instead of system: the file returns a system, or
                       {system = sys, run = function(sys, point) ... end}
  jobs = n             worker processes (default: every core online; jobs = 1
                       runs in this process).  Workers are fork()ed: the
                       system and run (closures too) need no serialization,
                       and the results come back bit for bit.
  out = "results.csv"  a header (the inputs, the outputs, error), then one row
                       per point, appended and flushed as each point finishes.
                       When the file exists with this sweep's inputs, the
                       sweep resumes: only the missing points are computed
                       (resume = false starts over; a file of other columns is
                       refused, never overwritten).  A cut last line is dropped.
  retry = true         with a resume, compute the points recorded with an error
                       again (the new row is appended: a point's last row
                       counts)
  progress = false     no progress bar (shown on a terminal: points done, time
                       left)
  todo = "points.txt"  write the points still missing, one per line, and run
                       nothing: the input of nzlua --sweep-worker (see
                       help("sweep_worker")) under GNU parallel or a job array
  from = "done.txt"    take the rows of these files (worker output, or CSV) as
                       done: they are added to out and not computed
  parallel = "--sshloginfile hosts"   run the missing points through GNU
                       parallel with these options (needs 'file'; 10 points
                       per job unless -N or --block is given); each row is
                       appended to out as it comes back; points no host
                       answered for stay missing (rows.status "incomplete")
  worker = "nzlua"     the command that runs nzlua on the hosts
A point whose run fails is recorded with its message in the column error (its
outputs empty) and the others go on; a worker that dies loses only its point.
Returns the rows in the order of the points (inputs, outputs, error), with
rows.status ("complete", "interrupted", "incomplete", "todo"), rows.computed,
rows.resumed, rows.failed.  Ctrl-C stops dispatching, ends the workers and
returns the rows finished (rows.missing says how many are not; they are in
out); the next nz.sweep in the script raises nz.interrupted.
Limits: at most 1e7 points (require("nz.motion.sweep").MAX_POINTS).]] },
  { name = "sweep_worker", section = "mechanics", optional = true,
    usage = "nzlua --sweep-worker file.lua < points.txt > results.txt",
    summary = "run a sweep's points from stdin (one per line), result rows to stdout (GNU parallel, Slurm)",
    text = [[
file.lua returns {system = sys, run = function(sys, point) ... end}.  Each line
of stdin is a point, name=value separated by spaces (amp=0.5 l=1; strings in
double quotes with \\ \" \n escaped; # starts a comment line).  Each line of
stdout is the point's inputs, its outputs and, when run failed, error="...",
in the same format, flushed as each point finishes.  A line that is not a point
is reported on stderr (the others go on; the exit status is then 1).
Across machines (the same nzlua and file on each), in one call:
  nz.sweep{file = "f.lua", grid = {...}, out = "r.csv",
           parallel = "--sshloginfile hosts"}
or in three steps (the points, GNU parallel, the rows into r.csv):
  nz.sweep{file = "f.lua", grid = {...}, out = "r.csv", todo = "todo.txt"}
  parallel --pipe -N 10 --sshloginfile hosts nzlua --sweep-worker f.lua \
      < todo.txt > done.txt
  nz.sweep{file = "f.lua", grid = {...}, out = "r.csv", from = "done.txt"}
A Slurm job array: task i runs line i,
  sed -n "${SLURM_ARRAY_TASK_ID}p" todo.txt | nzlua --sweep-worker f.lua \
      > done.$SLURM_ARRAY_TASK_ID.txt
then from = {"done.1.txt", ...} (or cat them into one file).]] },
  { name = "methods", section = "mechanics", usage = "nz.methods",
    summary = "GSL's steppers for sys:simulate: {name =, implicit =} each" },
  { name = "last", section = "mechanics", usage = "nz.last", optional = true,
    summary = "the trajectory a failed or interrupted sys:simulate had computed" },
  { name = "cache", section = "session", usage = "nz.cache.info(), nz.cache.clear(), nz.cache.dir()",
    summary = "the cache of machine code: where, how big, whether trusted; empty it",
    text = [[
Recorded systems compile their plans to machine code with the system's C
compiler and keep the objects in $NZLUA_CACHE, else $XDG_CACHE_HOME/nzlua,
else ~/.cache/nzlua (no HOME: no cache, the interpreter runs).
  nz.cache.info()   {dir, objects, bytes, limit, trusted [, why], sources,
                    others}: trusted when it is yours alone (owner, not
                    writable by group or others): nothing is loaded otherwise
  nz.cache.clear()  remove nzlua's files there (the count); they are
                    compiled again when needed (nzlua --cache-clear)
  nz.cache.dir()    the directory, or nil and why there is none
Each object is checked before it is loaded (owner, mode, size, a checksum,
its ELF segments); a damaged one is removed and compiled again.  Compiles
run in the background (sys.engine.recording:native_wait() waits for them);
NZLUA_CACHE_MAX bounds the cache (default 100M, least recently used out
first), NZLUA_CC_TIMEOUT limits a compile (300 s), NZLUA_CC_JOBS the
compiles at once (2), NZLUA_KEEP_C=1 keeps the generated C.]] },
  { name = "special", section = "session", usage = "nz.special.ellint_K(k), nz.special.elljac(u, m)",
    summary = "GSL's complete elliptic integral K(k) of the modulus k, and Jacobi's sn, cn, dn of the parameter "
      .. "m = k^2 (for closed forms)",
    text = [[
The two take the same curve in different variables, as GSL does:
  nz.special.ellint_K(k)      K(k), the modulus k in (-1, 1)
  nz.special.elljac(u, m)     sn(u|m), cn(u|m), dn(u|m): the PARAMETER
                              m = k^2 in [0, 1], not the modulus
so sn(K(k) | k^2) = 1.  The pendulum of amplitude a (l, g): k = sin(a/2),
period 4 K(k) sqrt(l/g), th(t) = 2 asin(k sn(K(k) - t sqrt(g/l) | k^2)) from
th(0) = a at rest.]] },
  { name = "partial", section = "operators", usage = "nz.partial(n, f, t, q, qd [, qdd, higher])",
    summary = "d f^(n) / d q^(n): the n-th time derivative of f, differentiated by q^(n)",
    text = [[
Computed with jets as docs/theory.md §3 says (f differentiated n times along
the motion, the partial taken by a tangent seeded on q^(n)).  n = 0 gives
df/dq.  By (2.1) it equals n d/dt(df/dqd) + df/dq.  k values.]] },
  { name = "top_coefficient", section = "operators", usage = "nz.top_coefficient(m, f, t, q, qd [, qdd])",
    summary = "d f^(m-1) / d q^(m): the coefficient of the top derivative (equals df/dqd)" },
  { name = "nielsen_op", section = "operators", usage = "nz.nielsen_op(m, f, t, q, qd [, qdd, higher])",
    summary = "N^m(f) = d f^(m)/dq^(m) - 2 d f^(m-1)/dq^(m-1)  (docs/theory.md (5.1))" },
  { name = "euler_op", section = "operators", usage = "nz.euler_op(m, f, t, q, qd [, qdd, higher])",
    summary = "E^m(f) = d/dt(d f^(m-1)/dq^(m)) - d f^(m-1)/dq^(m-1)  (docs/theory.md (5.2))" },
  { name = "help", section = "session", usage = "nz.help([f])",
    summary = "list what nz offers, or explain one function (help(nz.jet)), method (help(sys.simulate)) or effect "
      .. "(help(nz.effects.spring)); help(nil), a misspelled name, says so" },
  { name = "version", section = "session", usage = "nz.version", summary = "the version string" },
  { name = "interrupted", section = "session", usage = "err == nz.interrupted",
    summary = "the error Ctrl-C raises (prints as 'interrupted!'); compare by identity",
    text = [[
Ctrl-C during a computation raises this one object, so that code can tell an
interrupt from an error whatever the error's text says:
  local ok, err = pcall(f)
  if not ok and err == nz.interrupted then ... end
sys:simulate catches it and returns the part computed (also in nz.last; a
partial trajectory, stderr says so); tr:csv leaves the previous file (a
SIGTERM waits until the file is complete).  In a script the next
sys:simulate raises nz.interrupted, which stops the script; a script that
Ctrl-C reached exits with status 130 (128 + SIGINT).]] },
}

M.entries = entries

-- Help is read in a terminal: every line fits in M.WIDTH columns (a test
-- checks every text); the usages and summaries are wrapped here.
M.WIDTH = require("nz.base.text").WIDTH

-- The words of a text in lines of at most M.WIDTH columns (nz/base/text.lua).
local wrap = require("nz.base.text").wrap
M.wrap = wrap
local function width(s) return utf8.len(s) or #s end

local function find(nz, what)
  for _, e in ipairs(entries) do
    if what == e.name or (type(what) ~= "string" and rawequal(nz[e.name], what)) then return e end
  end
end

local function entry_text(e)
  return ("%s\n%s\n%s"):format(wrap(e.usage, "", "    "), wrap(e.summary, "  ", "  "), e.text and ("\n" .. e.text) or "")
end

-- ------------------------------------------------------------------ --
-- Methods: help(sys.simulate), help(tr.plot), help(lin.modes)          --

-- The objects nz makes and where their methods are explained.  A system's
-- and a trajectory's methods have paragraphs of their own in
-- help(nz.system), read from there (one text, never two that differ); a
-- linearization's and an eigenvalue sweep's are explained in the paragraph
-- of the method that makes them.
local function classes()
  return {
    { class = require("nz.base.classes").System, prefix = "sys", what = "a system" },
    { class = require("nz.motion.trajectory").Trajectory, prefix = "tr", what = "a trajectory" },
    { class = require("nz.analysis.linearize").Linear, prefix = "lin", what = "a linearization (sys:linearize)",
      under = "sys:linearize" },
    { class = require("nz.analysis.eigen_sweep").Sweep, prefix = "sw", what = "an eigenvalue sweep (sys:eigen_sweep)",
      under = "sys:eigen_sweep" },
  }
end

-- The paragraphs after "Methods" in help(nz.system): each starts with a
-- line indented by two spaces ("  sys:accel(t, q, qd ...)") and goes on
-- with the lines indented further.
local function paragraphs()
  local out, cur, started = {}, nil, false
  local text = find({}, "system").text
  for line in (text .. "\n"):gmatch("(.-)\n") do
    if line:match("^Methods") then
      started = true
    elseif started then
      if line:match("^  %S") then
        cur = { line }
        out[#out + 1] = cur
      elseif line:match("^%S") then
        cur = nil
      elseif cur then
        cur[#cur + 1] = line
      end
    end
  end
  return out
end

-- The paragraphs whose first line names `call` ("sys:simulate") as a call.
local function paragraphs_of(call)
  local found = {}
  for _, p in ipairs(paragraphs()) do
    if p[1]:find(call:gsub("%p", "%%%0") .. "[%({]") then found[#found + 1] = table.concat(p, "\n") end
  end
  return found
end
M.paragraphs_of = paragraphs_of

-- The method `what` (a function, or a name "sys:simulate", "simulate"):
-- its class's record and its name, or nil.
local function find_method(what)
  for _, c in ipairs(classes()) do
    for name, f in pairs(c.class) do
      if type(f) == "function" and not name:match("^__") then
        if rawequal(f, what) or what == name or what == c.prefix .. ":" .. name then return c, name end
      end
    end
  end
end

local function method_text(c, name)
  local call = c.prefix .. ":" .. name
  local found = paragraphs_of(c.under or call)
  local head = c.under and ("%s: a method of %s, explained with %s:"):format(call, c.what, c.under)
    or ("%s: a method of %s (help(nz.system) describes them all):"):format(call, c.what)
  if #found == 0 then return nil end
  return head .. "\n\n" .. table.concat(found, "\n")
end

-- A jet's methods (x:coef, ...) are explained in help(nz.jet).
local function jet_method(nz, what)
  local mt = getmetatable(nz.jet(0, 1))
  if type(mt.__index) ~= "table" then return nil end
  for name, f in pairs(mt.__index) do
    if rawequal(f, what) then return name end
  end
end

-- ------------------------------------------------------------------ --
-- Effects: help(nz.effects.spring)                                     --

local KINDS = { number = "a number", coordinate = "a coordinate's name", coordinates = "a list of coordinate names",
  ["function"] = "a function", vector = "a vector {x, y, z}", point = "a point", pair = "two points {A, B}" }

local function effect_text(nz, kind)
  local effects = nz.effects
  local lines = {}
  -- its lines in help(nz.effects): the parameters as they are written
  for line in find(nz, "effects").text:gmatch("[^\n]+") do
    if line:match("^  " .. kind .. "{") then
      lines[#lines + 1] = line
    end
  end
  local out = { wrap(("nz.effects.%s{...}: an effect of a scene (help(nz.effects) lists them)"):format(kind),
    "", "    "), wrap(effects.docs[kind] or "", "  ", "  "), "" }
  for _, l in ipairs(lines) do out[#out + 1] = l end
  local spec = effects.specs[kind]
  local names = {}
  for name in pairs(spec) do names[#names + 1] = name end
  table.sort(names)
  out[#out + 1] = ""
  out[#out + 1] = "Parameters (* required):"
  local points = false
  for _, name in ipairs(names) do
    local s = spec[name]
    local doc = s.doc
    if not doc then
      doc = KINDS[s.type] or s.type
      if s.positive then doc = doc .. ", positive" elseif s.nonnegative then doc = doc .. ", not negative" end
    end
    out[#out + 1] = wrap(doc, ("  %-12s "):format(name .. (s.required and " *" or "")), (" "):rep(15))
    points = points or s.type == "point" or s.type == "pair"
  end
  if points then
    out[#out + 1] = wrap("A point is a body's name, a function (t, q, params) -> {x, y, z} (a moving support) or a "
      .. "fixed {x, y, z}.", "", "")
  end
  out[#out + 1] = "A wrong or missing parameter is an error naming the effect and the parameter."
  return table.concat(out, "\n")
end

local function effect_kind(nz, what)
  for kind, f in pairs(nz.effects) do
    if rawequal(f, what) and nz.effects.docs[kind] then return kind end
  end
  if type(what) == "string" then
    local kind = what:match("^effects%.([%w_]+)$")
    if kind and nz.effects.docs[kind] then return kind end
  end
end

-- A function inside a table of nz (nz.rotations.z, nz.special.elljac):
-- the table's entry and the function's name.
local function member(nz, what)
  if type(what) ~= "function" then return nil end
  for _, e in ipairs(entries) do
    local t = nz[e.name]
    if type(t) == "table" and not getmetatable(t) then
      for name, f in pairs(t) do
        if rawequal(f, what) then return e, name end
      end
    end
  end
end

-- ------------------------------------------------------------------ --
-- The listing                                                          --

local function listing(nz)
  local out = { ("nz %s: analytical mechanics with Taylor jets.  help(f) explains f."):format(nz.version) }
  local pad = (" "):rep(31)
  for _, s in ipairs(sections) do
    out[#out + 1] = ""
    out[#out + 1] = s.title
    for _, e in ipairs(entries) do
      if e.section == s.id then
        local usage = e.usage:match("^(.-)  |  ") or e.usage    -- the first of two forms
        if width(usage) <= 28 then
          out[#out + 1] = wrap(e.summary, ("  %-28s "):format(usage), pad)
        else
          out[#out + 1] = wrap(usage, "  ", "      ")
          out[#out + 1] = wrap(e.summary, pad, pad)
        end
      end
    end
  end
  -- the methods, by name: help(sys.NAME) or help("sys:NAME") explains one
  for _, c in ipairs(classes()) do
    if not c.under then
      local names = {}
      for name, f in pairs(c.class) do
        if type(f) == "function" and not name:match("^__") then names[#names + 1] = name end
      end
      table.sort(names)
      out[#out + 1] = ""
      out[#out + 1] = ("Methods of %s (help(%s.NAME) explains one)"):format(c.what, c.prefix)
      out[#out + 1] = wrap(table.concat(names, ", "), "  ", "  ")
    end
  end
  out[#out + 1] = ""
  out[#out + 1] = wrap("help(sys), help(tr), help(lin), help(sw): what the system, trajectory, linearization or "
    .. "eigenvalue sweep you hold is, every field it holds (tr.events, tr.stats, ...) and its methods, one line each "
    .. "(help(\"tr\") without one)", "", "  ")
  return table.concat(out, "\n")
end

-- bind(nz) returns the help function of that module table: help() lists,
-- help(f) explains f (a function of nz, a method found by its value, an
-- effect), help(nil) says the value is nil (a misspelled name gives nil).
function M.bind(nz)
  return function(...)
    local what, opts = ...
    local text
    if what == nil and select("#", ...) == 1 then
      text = "help(nil): the value is nil (a misspelled name?): help() lists what nz offers"
    elseif what == nil then
      text = listing(nz)
    else
      local e = find(nz, what)
      local c, name = nil, nil
      if not e then c, name = find_method(what) end
      local kind = not e and not c and effect_kind(nz, what)
      local jet = not e and not c and not kind and type(what) == "function" and jet_method(nz, what)
      local parent, field = nil, nil
      if not (e or c or kind or jet) then parent, field = member(nz, what) end
      -- an object a session holds: a system, a trajectory, a linearization, a sweep
      local object = not (e or c or kind or jet or parent) and require("nz.session.help_objects").find(what)
      if e then
        text = entry_text(e)
      elseif c then
        text = method_text(c, name)
      elseif kind then
        text = effect_text(nz, kind)
      elseif jet then
        text = ("x:%s: a method of every jet, explained in help(nz.jet):\n\n%s"):format(jet, entry_text(find(nz, "jet")))
      elseif parent then
        text = ("nz.%s.%s: explained in help(nz.%s):\n\n%s"):format(parent.name, field, parent.name, entry_text(parent))
      elseif object then
        text = require("nz.session.help_objects").text(object, what)
      end
      if not text then
        -- one line, not an error: at the prompt a traceback would bury it
        text = ("no help for %s: help() lists what nz offers"):format(
          type(what) == "string" and ("'" .. what .. "'") or ("this " .. type(what)))
      end
    end
    if opts and opts.quiet then return text end
    print(text)
    return nil
  end
end

return M
