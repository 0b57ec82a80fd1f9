-- helpers.lua - what several spec files share: loading nz the way the suite
-- runs (plain lua5.4 + build/nz.so, or inside nzlua), comparing series, and
-- running the nzlua program as a black box.
local M = {}

M.nz = rawget(_G, "nz") or require("nz")

-- The program under test: build/nzlua, or the sanitized one (NZLUA=...).
M.nzlua = os.getenv("NZLUA") or "build/nzlua"

-- Worst error of coefficient-wise comparison; scale(j) sets what "relative"
-- means for coefficient j (by default max(|want_j|, 1)).
function M.worst_error(got, want, K, scale)
  local worst, at = 0, 0
  for j = 0, K do
    local g = type(got) == "function" and got(j) or got:coef(j)
    local w = type(want) == "function" and want(j) or want:coef(j)
    local s = scale and scale(j) or math.max(math.abs(w), 1)
    local e = math.abs(g - w) / s
    if e ~= e then e = math.huge end
    if e > worst then worst, at = e, j end
  end
  return worst, at
end

function M.assert_series(got, want, K, tol, what, scale)
  local e, at = M.worst_error(got, want, K, scale)
  assert(e <= tol, ("%s: coefficient %d off by %.3g (relative), expected <= %.3g"):format(
    what, at, e, tol))
end

-- Gauss-Legendre quadrature of f on [a, b] in n panels of 10 points (the
-- closed forms the contact tests compare with: times by quadrature).
local GX = { -0.9739065285171717, -0.8650633666889845, -0.6794095682990244, -0.4333953941292472, -0.1488743389816312,
  0.1488743389816312, 0.4333953941292472, 0.6794095682990244, 0.8650633666889845, 0.9739065285171717 }
local GW = { 0.0666713443086881, 0.1494513491505806, 0.2190863625159820, 0.2692667193099963, 0.2955242247147529,
  0.2955242247147529, 0.2692667193099963, 0.2190863625159820, 0.1494513491505806, 0.0666713443086881 }
function M.gauss_legendre(f, a, b, n)
  local s = 0
  for i = 0, n - 1 do
    local lo, hi = a + (b - a) * i / n, a + (b - a) * (i + 1) / n
    for j = 1, 10 do s = s + 0.5 * (hi - lo) * GW[j] * f(0.5 * (lo + hi) + 0.5 * (hi - lo) * GX[j]) end
  end
  return s
end

-- The contact events of a trajectory of one kind ("impact", "sticks", ...;
-- nil: any) and of one contact (nil: any), in order.
function M.contact_events(tr, kind, name)
  local out = {}
  for _, ev in ipairs(tr.events) do
    if (not kind or ev.kind == kind) and (not name or ev.name == name) then out[#out + 1] = ev end
  end
  return out
end

-- The largest |v[i]|.
function M.max_abs(v)
  local m = 0
  for i = 1, #v do m = math.max(m, math.abs(v[i])) end
  return m
end

-- |a - b| <= tol, else a failure naming what and both values.
function M.near(a, b, tol, what)
  assert(math.abs(a - b) <= tol, ("%s: %.17g, expected %.17g"):format(what, a, b))
end

-- A file's whole text, or nil when it cannot be read.
function M.slurp(path)
  local f = io.open(path, "rb")
  if not f then return nil end
  local text = f:read("a")
  f:close()
  return text
end

-- The non-empty lines of a text.
function M.lines(text)
  local out = {}
  for line in text:gmatch("[^\n]+") do out[#out + 1] = line end
  return out
end

-- Run a shell command; returns exit code, stdout, stderr.
function M.run(cmd, stdin)
  local out, err = os.tmpname(), os.tmpname()
  local full = cmd .. " >" .. out .. " 2>" .. err
  if stdin then
    local inp = os.tmpname()
    local f = assert(io.open(inp, "w")); f:write(stdin); f:close()
    full = full .. " <" .. inp
  else
    full = full .. " </dev/null"
  end
  local ok, how, code = os.execute(full)
  local function slurp(p) local f = io.open(p); local s = f and f:read("a") or ""; if f then f:close() end; os.remove(p); return s end
  if how == "signal" then code = 128 + code end
  return ok and 0 or code, slurp(out), slurp(err)
end

-- Run a Lua script (its text) with nzlua and send it Ctrl-C (SIGINT)
-- after `seconds`: exit code, stdout, stderr.
function M.interrupt_script(text, seconds)
  local script = os.tmpname()
  local f = assert(io.open(script, "w"))
  f:write(text)
  f:close()
  local code, out, err = M.run(("timeout --foreground --preserve-status -s INT %g %s %s"):format(seconds, M.nzlua, script))
  os.remove(script)
  return code, out, err
end

-- Expect f(...) to raise an error containing `pattern` (plain text).
function M.checkerror(pattern, f, ...)
  local ok, msg = pcall(f, ...)
  assert(not ok, ("expected an error containing %q, but the call succeeded"):format(pattern))
  assert(tostring(msg):find(pattern, 1, true),
    ("expected an error containing %q, got %q"):format(pattern, tostring(msg)))
end

-- A reference run written here, independent of the stepping loop of
-- src/ode/ode_run.c: the same integrator (core.mech.ode_new) stepped from
-- Lua to each output time of the grid t0 + i dt (the last t1), adaptive
-- steps towards it or fixed steps no longer than `step` that land on it,
-- with q, qd, the whole state y and (mech.ode_accel) q'' and lambda at
-- each point.  A run of
-- sys:simulate with dense = false takes the same steps, so the two agree
-- to the bit: what the loop adds (buffers, pauses, resumption, the grid's
-- arithmetic) changes nothing.  opts: q0, qd0, t0, t1, dt, method, rtol,
-- atol, step, h0 (as sys:simulate), and what the integrator needs beside
-- them (orders, linear, alpha, beta, work, level, top; y0: the whole start
-- state).
function M.reference_run(sys, opts)
  local mech = require("nz.core").mech
  local k = sys.k
  local t0, t1 = opts.t0 or 0, opts.t1
  local dt = opts.dt or (t1 - t0) / 200
  local cfg = { method = opts.method or "rk8pd", rtol = opts.rtol or 1e-10, atol = opts.atol or 1e-12,
    h0 = opts.h0 or math.min(dt, 1e-3), orders = opts.orders or {}, linear = opts.linear or {}, alpha = opts.alpha,
    beta = opts.beta, work = opts.work, level = opts.level, top = opts.top }
  local engine = sys.engine
  engine.orders = cfg.orders
  local ode = mech.ode_new(engine, cfg)
  local y = opts.y0
  if not y then
    y = {}
    for i = 1, k do y[i], y[k + i] = opts.q0[i], opts.qd0 and opts.qd0[i] or 0 end
    if opts.work then y[2 * k + 1] = 0 end
  end
  local tr = { t = {}, q = {}, qd = {}, qdd = {}, lambda = {}, y = {} }
  local function record(t)
    local n = #tr.t + 1
    local q, qd = {}, {}
    for i = 1, k do q[i], qd[i] = y[i], y[k + i] end
    tr.t[n], tr.q[n], tr.qd[n], tr.y[n] = t, q, qd, { table.unpack(y) }
    tr.qdd[n], tr.lambda[n] = mech.ode_accel(ode, engine, t, y)
  end
  -- fixed steps: the time is t + tlo (Knuth's two-sum, then renormalized),
  -- the last step of an interval the rest to its output time
  local function add(hi, lo, d)
    local s = hi + d
    local bp = s - hi
    local l = lo + ((hi - (s - bp)) + (d - bp))
    local t2 = s + l
    return t2, l - (t2 - s)
  end
  local t, tlo, h = t0, 0, cfg.h0
  record(t)
  local nout = math.ceil((t1 - t0) / dt - 1e-9)
  for i = 1, nout do
    local tout = i == nout and t1 or t0 + i * dt
    local nfixed = opts.step and math.max(1, math.ceil((tout - t) / opts.step - 1e-9))
    local hfixed = opts.step and ((tout - t) - tlo) / nfixed
    while t < tout do
      if opts.step then
        local hstep = nfixed == 1 and (tout - t) - tlo or hfixed
        nfixed = nfixed - 1
        local _
        _, y = mech.ode_step_fixed(ode, engine, t, hstep, y)
        t, tlo = add(t, tlo, hstep)
        if nfixed == 0 then t, tlo = tout, tlo + (t - tout) end
      else
        t, h, y = mech.ode_step(ode, engine, t, tout, h, y)
      end
    end
    record(t)
  end
  tr.stats = mech.ode_stats(ode)
  return tr
end

-- Base64 decoded (RFC 4648), written here apart from the library's
-- encoder: an image in a data URI read back as its bytes.
function M.unbase64(s)
  local alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/"
  local bits = s:gsub("[^%w+/]", ""):gsub(".", function(c)
    local v = alphabet:find(c, 1, true) - 1
    local out = {}
    for b = 5, 0, -1 do out[#out + 1] = (v >> b) & 1 end
    return table.concat(out)
  end)
  return (bits:gsub("%d%d%d%d%d%d%d%d", function(byte) return string.char(tonumber(byte, 2)) end):gsub("[01]+$", ""))
end

-- The bytes of the first <img src="data:MIME;base64,..."> in a page, or nil.
function M.img_data(html, mime)
  local coded = html and html:match('<img src="data:' .. mime:gsub("%p", "%%%0") .. ';base64,([^"]+)"')
  return coded and M.unbase64(coded)
end

-- Each case {changes, message} of a study's options: f(sys, base with the
-- changes) raises an error containing message (plain text), placed at the
-- line that called f (the call below, so the test holds wherever the line
-- check of args.error points: at the caller).
function M.option_errors(f, sys, base, cases)
  for _, case in ipairs(cases) do
    local o = {}
    for k, v in pairs(base) do o[k] = v end
    for k, v in pairs(case[1]) do o[k] = v end
    local line = debug.getinfo(1, "l").currentline + 1
    local ok, msg = pcall(f, sys, o)
    assert(not ok, case[2])
    msg = tostring(msg)
    assert(msg:find(case[2], 1, true), ("expected %q in %q"):format(case[2], msg))
    assert(msg:find(("^[^:]*helpers.lua:%d: "):format(line)), msg)
  end
end

-- Two conservative systems of the long runs, each with its energy written
-- here (not the engine's): Kepler's problem (mu = 1) and Henon and
-- Heiles' potential.
function M.kepler()
  local sys = M.nz.system{ name = "kepler", coords = { "x", "y" },
    T = function(t, q, qd) return (qd[1] ^ 2 + qd[2] ^ 2) / 2 end,
    V = function(t, q) return -1 / M.nz.sqrt(q[1] ^ 2 + q[2] ^ 2) end }
  return sys, function(q, v) return (v[1] ^ 2 + v[2] ^ 2) / 2 - 1 / math.sqrt(q[1] ^ 2 + q[2] ^ 2) end
end

function M.henon_heiles()
  local sys = M.nz.system{ name = "henon-heiles", coords = { "x", "y" },
    T = function(t, q, qd) return (qd[1] ^ 2 + qd[2] ^ 2) / 2 end,
    V = function(t, q) local x, y = q[1], q[2]; return (x ^ 2 + y ^ 2) / 2 + x ^ 2 * y - y ^ 3 / 3 end }
  return sys, function(q, v)
    local x, y = q[1], q[2]
    return (v[1] ^ 2 + v[2] ^ 2) / 2 + (x ^ 2 + y ^ 2) / 2 + x ^ 2 * y - y ^ 3 / 3
  end
end

-- The options that f(...) gave plot.lines (nz/draw/plot.lua), drawn
-- nowhere.
function M.plotted(f, ...)
  local plot = require "nz.draw.plot"
  local lines, drawn = plot.lines, nil
  plot.lines = function(o) drawn = o; return "" end
  local ok, err = pcall(f, ...)
  plot.lines = lines
  assert(ok, err)
  return drawn
end

return M
