-- nz/motion/contact_run.lua - a simulation with unilateral contacts: what
-- sys:simulate does differently when the system has contacts
-- (nz/model/contact.lua).  simulate.lua and run.lua call it at four places:
-- begin (the checks, the contacts' state for the run, the mode at the
-- start), attach (the trajectory and the loop), located (an event of the
-- contacts, located by the loop in C: the impact and the new mode,
-- src/mech/contact.c, and the run going on from there, src/ode/ode_run.c's
-- nz_run_jump), finish.  It integrates the contact system
-- (sys.contact.system: the constraints, then every gap and slip function)
-- with the integrator holding the mode (core.mech.contacts_*).
--
-- What a run records: tr.events gets one entry per contact that changed
-- (kind "impact", "closes", "opens", "sticks", "slips"), with its time, the
-- state before and after, the impulse and the kinetic energy lost;
-- tr.contacts the names, every mode with the time it began (for tr:plot and
-- tr:animate), the counts and the Zeno accumulations; tr.lambda holds the
-- bilateral multipliers, then each contact's normal force and, with
-- friction, its tangential force (columns "N.name" and "T.name").
local core = require "nz.core"
local constraints = require "nz.model.constraints"

local mech = core.mech
local M = {}

-- Transitions at one time (relative 1e-12) before the run fails: the
-- modes would cycle without the motion moving on.
M.CYCLE = 50
-- A start state's gap may be below zero by this fraction of its terms
-- (rounding); further down the contact is violated.
M.START_TOL = 1e-9

local Run = {}
Run.__index = Run
M.Run = Run   -- (for tests)

local function num(v) return require("nz.base.text").number(v) end
local function nums(v) return require("nz.base.text").list(v) end

-- What a run with contacts refuses, the checks of the contacts at the
-- start, and the mode there (an impact at t0 when a contact touches with
-- an approach speed).  fail(fmt, ...) raises simulate's error.
function M.begin(sys, cfg, q0, qd0, fail)
  local c = sys.contact
  local csys = c.system
  for _, refused in ipairs{
    { cfg.project, "'project'", "the contacts held are put back on their gaps at every event" },
    { cfg.alpha, "'baumgarte'", "the contacts held are put back on their gaps at every event" },
    { cfg.monitors.work, "the 'work' monitor", "each impact's loss of kinetic energy is in tr.events (energy_lost), "
      .. "and monitors = {energy = true} records T + V" } } do
    if refused[1] then fail("%s is not available with unilateral contacts: %s", refused[2], refused[3]) end
  end
  local orders, linear = constraints.orders(csys, { t = cfg.t0, q = q0, qd = qd0 })
  for r = 1, c.nb do
    if orders[r] > 1 or (orders[r] == 1 and not linear[r]) then
      fail("constraint %d is %s: beside unilateral contacts the constraints must be holonomic or linear in the "
        .. "velocities (their impulses are the constraint's own)", r,
        orders[r] > 1 and ("of order %d"):format(orders[r]) or "nonlinear in the velocities")
    end
  end
  local defs = {}
  -- (a gap receives (t, q, params), a slip (t, q, qd, params): of order 0
  -- and <= 1, as src/mech/contact.c takes them)
  for j, s in ipairs(c.contacts) do
    defs[j] = { gap = s.gap, slip = s.slip, slip2 = s.slip2, speed = s.speed, e = s.e, mu = s.mu, mu_s = s.mu_s }
  end
  local engine = csys.engine
  engine.orders = orders
  local cs = mech.contacts_new(engine, { nb = c.nb, orders = orders, contacts = defs, names = c.names,
    rtol = cfg.rtol, atol = cfg.atol })
  for j, kin in ipairs(mech.contacts_kinematics(cs, engine, cfg.t0, q0, qd0)) do
    if kin[1] < -M.START_TOL * kin[4] or (kin[4] == 0 and kin[1] < 0) then
      fail("contact '%s' (a unilateral constraint, gap >= 0) is violated at the start: its gap is %s at t = %s, q = %s: "
        .. "start with every gap at or above 0", c.names[j], num(kin[1]), num(cfg.t0), nums(q0))
    end
  end
  local self = setmetatable({ sys = sys, system = csys, engine = engine, cs = cs, orders = orders, linear = linear,
    names = c.names, n = c.n, specs = c.contacts, k = sys.k, cfg = cfg, same = 0, last_t = nil }, Run)
  local qd, rep, q = mech.contacts_transition(cs, engine, cfg.t0, q0, qd0, 0)
  self.start = { q = q0, qd = qd0, qd_after = qd, rep = rep }
  self.q0, self.qd0 = q, qd
  return self
end

-- The name of contact event e (1-based: 2j - 1 the normal one of contact
-- j, 2j its friction one).
function Run:event_name(e) return ("contact '%s'"):format(self.names[(e + 1) // 2]) end

-- The trajectory and the loop: loop = {run = function() return the run
-- (core.mech.ode_run_new) end}.  The start's changes are recorded.
function Run:attach(tr, loop)
  self.tr, self.loop = tr, loop
  tr.contacts = { names = self.names, modes = {}, impacts = 0, zeno = {}, run = self }
  tr.lambda_names = {}
  for r = 1, self.sys.contact.nb do tr.lambda_names[r] = "lambda" .. r end
  for j, s in ipairs(self.specs) do
    tr.lambda_names[s.gap] = "N." .. self.names[j]
    if s.slip2 then    -- an isotropic cone: its two components (its speed's column goes at the end: finish)
      tr.lambda_names[s.slip], tr.lambda_names[s.slip2] = "T1." .. self.names[j], "T2." .. self.names[j]
      tr.lambda_names[s.speed] = "|v_t|." .. self.names[j]
    elseif s.slip then tr.lambda_names[s.slip] = "T." .. self.names[j] end
  end
  self:record_changes(self.cfg.t0, self.start.q, self.start.qd, self.start.qd_after, self.start.rep, true)
end

local function energy(self, t, q, qd)
  local T = mech.energy(self.engine, t, q, qd)
  return T
end

local KIND = { open = "opens", closed = "closes", stick = "sticks", ["slip+"] = "slips", ["slip-"] = "slips", slip = "slips" }

-- tr.events for a transition at t from (q, qd) to qd_after, and the mode.
-- An impact gives an event to each contact that takes an impulse: those
-- that closed at a speed, and those touching at rest that pass the impulse
-- on (Newton's cradle: the middle ball's contact with the third); the
-- kinetic energy lost is on the first.
function Run:record_changes(t, q, qd, qd_after, rep, start)
  local tr = self.tr
  local lost
  if rep.impact then
    local T0, T1 = energy(self, t, q, qd), energy(self, t, q, qd_after)
    lost = T0 and T1 and T0 - T1
    tr.contacts.impacts = tr.contacts.impacts + 1
  end
  local states = {}
  for j, ch in ipairs(rep.contacts) do
    states[j] = ch.to
    local struck = rep.impact and (ch.impact or (ch.share and ch.Pn > 0))
    local kind = struck and "impact" or (ch.to ~= ch.from and KIND[ch.to]) or nil
    if kind and not (start and kind == "opens") then
      local ev = { name = self.names[j], contact = j, kind = kind, t = t, q = q, qd = qd, qd_after = qd_after,
        from = ch.from, to = ch.to, gap = ch.gap, normal_velocity = ch.vn_before, slip_velocity = ch.vt_before }
      if struck then
        ev.impulse, ev.tangential_impulse, ev.speed = ch.Pn, ch.Pt, math.max(0, -ch.vn_before)
        ev.energy_lost, lost = lost, nil          -- the impact's loss, on its first contact
      end
      if ch.zeno then
        ev.zeno = rep.zeno and rep.zeno.time
        tr.contacts.zeno[#tr.contacts.zeno + 1] = { contact = self.names[j], t = t, accumulation = ev.zeno }
      end
      tr.events[#tr.events + 1] = ev
    end
  end
  tr.contacts.modes[#tr.contacts.modes + 1] = { t = t, states = states }
end

-- Transitions at one time (te) one after the other: after M.CYCLE the
-- modes cycle without the motion going on, and the run fails.
function Run:guard(te, e)
  if self.last_t and math.abs(te - self.last_t) <= 1e-12 * math.max(1, math.abs(te)) then
    self.same = self.same + 1
    if self.same >= M.CYCLE then
      error(("%ssimulate '%s': the contacts' mode changed %d times at t = %s without the motion going on (the last "
        .. "event: %s): no consistent contact mode there (a contact closing and opening again and again)")
        :format(require("nz.base.where").user_where(), self.sys.name, self.same, num(te), self:event_name(e)), 0)
    end
  else
    self.same = 0
  end
  self.last_t = te
end

-- Contact event e (1-based among the contacts') at te, state ye, located
-- by the loop (which recorded the step's output points up to te, in the
-- mode before): the impact and the new mode
-- (core.mech.contacts_transition), recorded; the run goes on from te with
-- the new velocities.  Returns false (the run does not stop).
function Run:located(e, te, ye)
  local k = self.k
  self:guard(te, e)
  local q, qd = {}, {}
  for i = 1, k do q[i], qd[i] = ye[i], ye[k + i] end
  local qd_after, rep, q_after = mech.contacts_transition(self.cs, self.engine, te, q, qd, e)
  self:record_changes(te, q, qd, qd_after, rep)
  local y = { table.unpack(ye) }
  for i = 1, k do y[i], y[k + i] = q_after[i], qd_after[i] end
  mech.ode_run_jump(self.loop.run(), self.engine, te, y)
  return false
end

-- Keep only the multipliers `keep` (their numbers, in order) in tr.lambda,
-- its columns and its names: the rows made already lose the others, the
-- rows the trajectory makes later from its points never have them
-- (tr._lambda_cols, nz/motion/trajectory.lua).
local function keep_lambda(tr, keep)
  local names = {}
  for c, j in ipairs(keep) do names[c] = tr.lambda_names and tr.lambda_names[j] end
  if tr.lambda_names then tr.lambda_names = names end
  for i, row in next, tr.lambda do
    local kept = {}
    for c, j in ipairs(keep) do kept[c] = row[j] end
    rawset(tr.lambda, i, kept)
  end
  if tr._points then
    local base = tr._lambda_cols
    local cols = {}
    for c, j in ipairs(keep) do cols[c] = base and base[j] or j end
    tr._lambda_cols = cols
  end
end

-- After the run.
function Run:finish(tr)
  tr.contacts.run = nil
  tr.contacts.final = tr.contacts.modes[#tr.contacts.modes].states
  -- an isotropic cone's speed |v_t| is a row of Taylor's series, not a
  -- force: its column (always 0) leaves tr.lambda
  local drop = {}
  for _, s in ipairs(self.specs) do if s.speed then drop[s.speed] = true end end
  if next(drop) == nil then return end
  local keep = {}
  for r = 1, #tr.lambda_names do if not drop[r] then keep[#keep + 1] = r end end
  keep_lambda(tr, keep)
end

-- ------------------------------------------------------------------ --
-- What the trajectory shows                                          --

-- The summary line of print(tr): the impacts (each with its contacts'
-- impulses), the other changes, the energy lost, Zeno, the final mode.
function M.summary(tr)
  local c = tr.contacts
  local counts, lost = {}, 0
  for _, ev in ipairs(tr.events) do
    if ev.contact then
      counts[ev.kind] = (counts[ev.kind] or 0) + 1
      lost = lost + (ev.energy_lost or 0)
    end
  end
  local parts = {}
  if counts.impact then
    parts[1] = ("%d impact%s (%d impulse%s)"):format(c.impacts, c.impacts == 1 and "" or "s", counts.impact,
      counts.impact == 1 and "" or "s")
  end
  for _, kind in ipairs{ "closes", "opens", "sticks", "slips" } do
    local n = counts[kind]
    if n then
      local word = ({ closes = "closing", opens = "opening", sticks = "stick", slips = "slip" })[kind]
      parts[#parts + 1] = ("%d %s%s"):format(n, word, n == 1 and "" or "s")
    end
  end
  local lines = { ("  contacts (%s): %s%s"):format(table.concat(c.names, ", "),
    #parts > 0 and table.concat(parts, ", ") or "no change",
    counts.impact and (", kinetic energy lost in impacts %.6g"):format(lost) or "") }
  for _, z in ipairs(c.zeno) do
    lines[#lines + 1] = ("  Zeno: '%s' came to rest at t = %.10g (its impacts accumulate at t = %.10g)"):format(
      z.contact, z.t, z.accumulation)
  end
  if c.final then
    local st = {}
    for j, s in ipairs(c.final) do st[j] = ("%s %s"):format(c.names[j], s) end
    lines[#lines + 1] = "  final contact mode: " .. table.concat(st, ", ")
  end
  return table.concat(lines, "\n")
end

-- tr:residuals and tr:consistency measure the system's smooth equations,
-- without its contact forces and across its impacts: on a run with
-- contacts they would report the contacts as a defect.
function M.refuse_defect(tr, fname)
  error(("%str:%s: the run of '%s' has unilateral contacts: its motion is smooth only between its %d contact "
    .. "events, and its equations there hold the contact forces (tr.lambda, the columns N.name and T.name), "
    .. "which the smooth system's equations leave out; measure a stretch between two events of a run without "
    .. "them, or check the closed forms of the events (tr.events)"):format(require("nz.base.where").user_where(), fname,
    tr.system.name, #tr.events), 0)
end

-- The contact events as marks on tr:plot's curves against t: at each, the
-- value of each coordinate (q, and velocities before the event).
function M.marks(tr, series, x)
  if x ~= "t" then return end
  local coords = {}
  for j, c in ipairs(tr.coords) do coords[c] = j end
  local mx, my = {}, {}
  for _, s in ipairs(series) do
    local base, primes = s.name:match("^(.-)('*)$")
    local j = coords[base]
    if j and #primes <= 1 then
      for _, ev in ipairs(tr.events) do
        if ev.contact then
          mx[#mx + 1] = ev.t
          my[#my + 1] = #primes == 0 and ev.q[j] or ev.qd[j]
        end
      end
    end
  end
  if #mx > 0 then series[#series + 1] = { name = "contact events", x = mx, y = my, style = "points pt 7" } end
end

-- tr:animate's drawing with the contact points: each contact with a point
-- (at) is drawn there while it is held (axes: the plane's two axes, as
-- views.lua projects the bodies).
function M.drawing(tr, draw, axes)
  local c, specs = tr.contacts, tr.system.contact.contacts
  return function(t, q)
    local shapes = draw(t, q)
    local mode
    for _, m in ipairs(c.modes) do if m.t <= t then mode = m.states end end
    for j, s in ipairs(specs) do
      if s.at and mode and mode[j] ~= "open" then
        local p = s.at(t, q, tr.system.params)
        shapes.points = shapes.points or {}
        shapes.points[#shapes.points + 1] = { p[axes[1]], p[axes[2]], contact = c.names[j] }
      end
    end
    return shapes
  end
end

return M
