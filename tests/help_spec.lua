-- help_spec.lua - nz.help lists exactly what the module offers.
local h = require "tests.helpers"
local nz = h.nz
local entries = require("nz.session.help").entries

describe("nz.help", function()
  it("has one entry for every public name of nz, and no entry for a missing one", function()
    local documented = {}
    for _, e in ipairs(entries) do
      documented[e.name] = true
      assert(e.optional or nz[e.name] ~= nil, ("help documents nz.%s, which does not exist"):format(e.name))
    end
    for name in pairs(nz) do
      assert(documented[name], ("nz.%s has no help entry"):format(name))
    end
  end)
  -- the listing wraps its lines: compare with the spaces collapsed
  local function words(s) return (s:gsub("%s+", " ")) end
  it("lists every entry with its whole usage and summary", function()
    local text = words(nz.help(nil, { quiet = true }))
    for _, e in ipairs(entries) do
      assert(text:find(words(e.summary), 1, true), ("the listing lacks the summary of %s"):format(e.name))
      -- the first of two forms (nz.jet(...) | nz.jet{...}), never cut at a | inside one (nz.sweep's)
      local usage = words(e.usage:match("^(.-)  |  ") or e.usage)
      assert(text:find(usage, 1, true), ("the listing cuts the usage of %s: %s"):format(e.name, usage))
    end
  end)
  it("lists every method of a system and of a trajectory by name", function()
    local text = nz.help(nil, { quiet = true })
    local sys = nz.system{ name = "p", coords = { "x" }, T = function(t, q, qd) return qd[1] ^ 2 / 2 end }
    local tr = sys:simulate{ q0 = { 0 }, qd0 = { 1 }, t1 = 0.1 }
    for _, o in ipairs{ { sys, "Methods of a system" }, { tr, "Methods of a trajectory" } } do
      local at = assert(text:find(o[2], 1, true), o[2])
      local section = words(text:sub(at):match("^[^\n]*\n(.-)\n\n") or text:sub(at))
      for name, f in pairs(getmetatable(o[1]).__index) do
        if type(f) == "function" and not name:match("^_") then
          assert(section:find("%f[%w_]" .. name .. "%f[^%w_]"), ("%s lacks %s:\n%s"):format(o[2], name, section))
        end
      end
    end
  end)
  it("keeps every line of every help text within 80 columns", function()
    local texts = { listing = nz.help(nil, { quiet = true }) }
    for _, e in ipairs(entries) do texts[e.name] = nz.help(e.name, { quiet = true }) end
    local sys = nz.system{ name = "p", coords = { "x" }, T = function(t, q, qd) return qd[1] ^ 2 / 2 end }
    local tr = sys:simulate{ q0 = { 0 }, qd0 = { 1 }, t1 = 0.1 }
    for _, o in ipairs{ sys, tr } do
      for name, f in pairs(getmetatable(o).__index) do
        if type(f) == "function" and not name:match("^_") then texts[name] = nz.help(f, { quiet = true }) end
      end
    end
    for kind in pairs(nz.effects.docs) do texts["effects." .. kind] = nz.help(nz.effects[kind], { quiet = true }) end
    local n = 0
    for name, text in pairs(texts) do
      for line in text:gmatch("[^\n]+") do
        assert(utf8.len(line) <= 80, ("help of %s has a line of %d columns:\n%s"):format(name, utf8.len(line), line))
        n = n + 1
      end
    end
    assert(n > 500, n)
  end)
  it("explains one function given the function or its name", function()
    local text = nz.help(nz.jet, { quiet = true })
    assert.truthy(text:find("normalized coefficients c_0..c_K", 1, true), text)
    assert.are.equal(text, nz.help("jet", { quiet = true }))
  end)
  it("help(nil), what a misspelled name gives, says the value is nil; help() lists", function()
    local rc, out = h.run(h.nzlua .. " -i", "help(nz.simulte)\nhelp()\n")
    assert.are.equal(0, rc)
    assert.truthy(out:find("help(nil): the value is nil (a misspelled name?): help() lists what nz offers", 1, true), out)
    assert.truthy(out:find("Mechanical systems and their equations of any order", 1, true), out)   -- help() still lists
    local _, n = out:gsub("help%(f%) explains f%.", "")
    assert.are.equal(1, n, out)    -- help(nil) did not list
  end)
  it("says what to do when there is no help, in one line and without an error", function()
    assert.are.equal("no help for 'nothing_here': help() lists what nz offers", nz.help("nothing_here", { quiet = true }))
    assert.are.equal("no help for this table: help() lists what nz offers", nz.help({}, { quiet = true }))
    -- in the session: the line, no traceback
    local rc, out = h.run(h.nzlua .. " -i", "help(42)\n")
    assert.are.equal(0, rc)
    assert.truthy(out:find("no help for this number: help() lists what nz offers", 1, true), out)
    assert.falsy(out:find("traceback", 1, true), out)
  end)

  it("covers every method of a system and of a trajectory", function()
    local text = nz.help(nz.system, { quiet = true })
    local sys = nz.system{ name = "p", coords = { "x" }, T = function(t, q, qd) return qd[1] ^ 2 / 2 end }
    local System = getmetatable(sys).__index
    for name, f in pairs(System) do
      if type(f) == "function" and not name:match("^_") then
        assert(text:find("sys:" .. name, 1, true), ("help(nz.system) does not mention sys:%s"):format(name))
      end
    end
    local tr = sys:simulate{ q0 = { 0 }, qd0 = { 1 }, t1 = 0.1 }
    local Traj = getmetatable(tr).__index
    local ttext = text     -- the trajectory's methods are in help(nz.system)
    for name, f in pairs(Traj) do
      if type(f) == "function" and not name:match("^_") then
        assert(ttext:find("tr:" .. name, 1, true), ("help(nz.system) does not mention tr:%s"):format(name))
      end
    end
  end)
  it("explains each method found by its value: help(sys.simulate), help(tr.plot), help(lin.modes)", function()
    local sys = nz.system{ name = "p", coords = { "x" }, T = function(t, q, qd) return qd[1] ^ 2 / 2 end,
      V = function(t, q) return q[1] ^ 2 / 2 end }
    local tr = sys:simulate{ q0 = { 0 }, qd0 = { 1 }, t1 = 0.1 }
    for _, o in ipairs{ { sys, "sys" }, { tr, "tr" } } do
      for name, f in pairs(getmetatable(o[1]).__index) do
        if type(f) == "function" and not name:match("^_") then
          local text = nz.help(f, { quiet = true })
          -- its own paragraph of help(nz.system): its first line names the call
          local call = o[2] .. ":" .. name
          assert(text:find("\n  [^\n]-" .. call:gsub("%p", "%%%0") .. "[%({]"), ("help(%s.%s) gives:\n%s"):format(o[2], name, text))
          assert.are.equal(text, nz.help(call, { quiet = true }))
        end
      end
    end
    -- the paragraphs that were cut or missing: export's constraints, graph_info
    assert.truthy(nz.help(sys.export, { quiet = true }):find("of order 2 must be linear in q''); the others,", 1, true))
    assert.truthy(nz.help(sys.graph_info, { quiet = true }):find("native_why", 1, true))
    -- a linearization's and a sweep's methods point to the paragraph of the method that makes them
    local lin = sys:linearize{ q = { 0 }, qd = { 0 } }
    assert.truthy(nz.help(lin.modes, { quiet = true }):find("^lin:modes: .-\n  sys:linearize{"))
    local sw = sys:eigen_sweep{ values = { 1, 2 }, at = function() return { q = { 0 }, qd = { 0 } } end }
    assert.truthy(nz.help(sw.csv, { quiet = true }):find("^sw:csv: .-\n  sys:eigen_sweep{"))
    -- a jet's, to help(nz.jet)
    assert.truthy(nz.help(nz.jet(0, 2).coef, { quiet = true }):find("normalized coefficients c_0..c_K", 1, true))
  end)
  it("explains each effect with its parameters: help(nz.effects.spring)", function()
    local n = 0
    for kind, doc in pairs(nz.effects.docs) do
      local text = nz.help(nz.effects[kind], { quiet = true })
      assert.truthy(text:find("nz.effects." .. kind .. "{", 1, true), text)
      assert.truthy(text:find(doc:match("^%S+ %S+ %S+"), 1, true), text)
      for param, spec in pairs(nz.effects.specs[kind]) do
        assert(text:find("\n  " .. param .. (spec.required and " %*" or "%s")), ("help of %s lacks %s:\n%s"):format(kind, param, text))
      end
      n = n + 1
    end
    assert(n >= 10, n)
  end)
  it("explains every function inside a table of nz (nz.rotations.z, nz.special.elljac) by its table's entry", function()
    local n = 0
    for name, t in pairs(nz) do
      if type(t) == "table" and not getmetatable(t) then
        for field, f in pairs(t) do
          if type(f) == "function" then
            local text = nz.help(f, { quiet = true })
            assert.falsy(text:find("^no help"), ("nz.%s.%s: %s"):format(name, field, text))
            n = n + 1
          end
        end
      end
    end
    assert(n >= 15, n)
    assert.truthy(nz.help(nz.rotations.z, { quiet = true }):find("^nz.rotations.z: explained in help%(nz.rotations%)"))
  end)
  it("help(nz.workprecision) says that taylor runs constrained systems, as it does", function()
    local sleigh = nz.system{ name = "sleigh", coords = { "x", "y", "th" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) + 0.5 * 0.3 * qd[3] ^ 2 end,
      constraints = { function(t, q, qd) return -qd[1] * nz.sin(q[3]) + qd[2] * nz.cos(q[3]) end } }
    local rows = nz.workprecision(sleigh, { budget = 0.01, q0 = { 0, 0, 0 }, qd0 = { 1, 0, 0.5 }, t1 = 1, methods = { "taylor" },
      tols = { 1e-8 }, quiet = true })
    assert.are.equal("done", rows[1].status)
    local text = nz.help(nz.workprecision, { quiet = true }):gsub("%s+", " ")
    assert.falsy(text:find("does not apply: constraints,", 1, true), text)
    assert.truthy(text:find("taylor runs free and constrained recorded systems", 1, true), text)
  end)
end)

-- The options a help text documents for a call: the names at the top level
-- of each table literal in its signature ("tr:plot{[y = {...}, x = "t",
-- file = "f.svg" | "f.png", title]}"; "sys:rule([{extremal = true}])"),
-- and the names after "opts:" where the signature says opts.
local function close_of(text, i)
  local depth, quote = 0, nil
  for j = i, #text do
    local c = text:sub(j, j)
    if quote then
      if c == quote then quote = nil end
    elseif c == '"' then quote = c
    elseif c == "(" or c == "{" then depth = depth + 1
    elseif c == ")" or c == "}" then
      depth = depth - 1
      if depth == 0 then return j end
    end
  end
  error("unbalanced signature: " .. text:sub(i, i + 80))
end

-- The top-level pieces of the inside of a group, split at sep.
local function split_top(inner, sep)
  local out, depth, quote, start = {}, 0, nil, 1
  for j = 1, #inner do
    local c = inner:sub(j, j)
    if quote then
      if c == quote then quote = nil end
    elseif c == '"' then quote = c
    elseif c == "(" or c == "{" then depth = depth + 1
    elseif c == ")" or c == "}" then depth = depth - 1
    elseif c == sep and depth == 0 then
      out[#out + 1] = inner:sub(start, j - 1)
      start = j + 1
    end
  end
  out[#out + 1] = inner:sub(start)
  return out
end

local function table_names(inner, into)
  for _, item in ipairs(split_top(inner, ",")) do
    for p, part in ipairs(split_top(item, "|")) do
      part = part:gsub("[%[%]]", " ")
      local name, rest = part:match("^%s*([%a_][%w_]*)%s*(.-)%s*$")
      if name and (rest:sub(1, 1) == "=" or (p == 1 and rest == "")) then into[name] = true end
    end
  end
end

local function documented(text, call)
  local names, found = {}, false
  local at = 1
  while true do
    local a, b = text:find(call:gsub("%p", "%%%0") .. "[%({]", at)
    if not a then break end
    found = true
    local close = close_of(text, b)
    local inner = text:sub(b + 1, close - 1)
    if text:sub(b, b) == "{" then
      table_names(inner, names)
      -- "... or {csv = ...}": another form of the same call
      local alt = text:sub(close + 1):match("^%s+or%s+()%{")
      if alt then
        local s = close + alt
        table_names(text:sub(s + 1, close_of(text, s) - 1), names)
      end
    else
      local j = 1
      while true do
        local o = inner:find("{", j, true)
        if not o then break end
        local c = close_of(inner, o)
        if inner:sub(1, o - 1):gsub("%b()", ""):find("[%(]") == nil then table_names(inner:sub(o + 1, c - 1), names) end
        j = c + 1
      end
      if inner:find("%f[%w_]opts%f[^%w_]") then
        local list = text:sub(close):match("opts: ([^;.]+)")
        assert(list, call .. ": the signature says opts, and no 'opts: a, b, ...' follows")
        for name in list:gmatch("[%a_][%w_]*") do names[name] = true end
      end
    end
    at = close + 1
  end
  return found and names or nil
end

describe("help signatures list what the code accepts", function()
  it("each method's documented options are the options its checker accepts, and no other", function()
    local sys = nz.system{ name = "p", coords = { "x" }, T = function(t, q, qd) return qd[1] ^ 2 / 2 end }
    sys:simulate{ q0 = { 0 }, qd0 = { 1 }, t1 = 0.1 }:plot{ width = 40, height = 12, quiet = true }    -- loads every module
    require "nz.presentation.views"; require "nz.analysis.defect"; require "nz.analysis.rumyantsev"; require "nz.presentation.show"; require "nz.presentation.export"
    require "nz.analysis.linearize"; require "nz.analysis.eigen_sweep"; require "nz.analysis.workprecision"; require "nz.motion.sweep"; require "nz.analysis.check"
    local accepted = require("nz.base.options").accepted
    local system_text = nz.help(nz.system, { quiet = true })
    local n, wrong = 0, {}
    for call, a in pairs(accepted) do
      local text = system_text
      local nzname = call:match("^nz%.([%w_]+)$")
      if nzname then text = nz.help(nzname, { quiet = true }) end
      local doc
      local outer, sub = call:match("^(%S+) (%S+)$")      -- "sys:export main": the table main = {...}
      if outer then
        local sig = assert(documented(text, outer) and text:match(outer:gsub("%p", "%%%0") .. "(%b{})"), call)
        local inner = sig:match(sub .. "%s*=%s*(%b{})")
        assert(inner, ("%s: no %s = {...} in its signature"):format(outer, sub))
        doc = {}
        table_names(inner:sub(2, -2), doc)
      else
        doc = documented(text, call)
      end
      assert(doc, ("help documents no signature of %s"):format(call))
      local names = {}
      for key, v in pairs(a.names) do
        local name = type(key) == "number" and v or key
        if name:sub(1, 1) ~= "_" then names[name] = true end
      end
      for name in pairs(names) do
        if not doc[name] then wrong[#wrong + 1] = ("%s accepts the option '%s', which its help does not list"):format(call, name) end
      end
      for name in pairs(doc) do
        if not (names[name] or (a.accept and a.accept(name))) then
          wrong[#wrong + 1] = ("the help of %s lists the option '%s', which it refuses"):format(call, name)
        end
      end
      n = n + 1
    end
    table.sort(wrong)
    assert(#wrong == 0, table.concat(wrong, "\n"))
    assert(n >= 25, n)
  end)
end)

describe("the options of every method are checked", function()
  it("sys:rule, sys:constraints, sys:project, sys:report and sw:plot refuse an unknown option, naming the nearest", function()
    local sys = nz.system{ name = "p", coords = { "x", "y" }, T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      V = function(t, q) return q[1] ^ 2 + q[2] ^ 2 end, constraints = { function(t, q) return q[1] - q[2] end } }
    h.checkerror("bad argument #1 to 'rule' (unknown option 'extremel' (did you mean 'extremal'?)", sys.rule, sys, { extremel = true })
    h.checkerror("bad argument #1 to 'constraints' (unknown option 'quite' (did you mean 'quiet'?)", sys.constraints, sys, { quite = true })
    h.checkerror("bad argument #4 to 'project' (unknown option 'maxiter' (did you mean 'maxit'?)", sys.project, sys, 0,
      { 1, 1 }, { 0, 0 }, { maxiter = 3 })
    h.checkerror("bad argument #1 to 'report' (unknown option 'simulte' (did you mean 'simulate'?)", sys.report, sys,
      { q = { 1, 1 }, simulte = false })
    local sw = sys:eigen_sweep{ values = { 1, 2 }, at = function() return { q = { 0, 0 } } end }
    h.checkerror("sw:plot: unknown option 'titel' (did you mean 'title'?)", sw.plot, sw, { titel = "x" })
    -- and accept what they document
    assert.are.equal(1, (sys:rule{ extremal = true }))
    assert.are.equal(0, sys:constraints{ quiet = true }[1].order)
    local q = sys:project(0, { 1, 0.8 }, { 0, 0 }, { tol = 1e-13, maxit = 20 })
    assert(math.abs(q[1] - q[2]) < 1e-13)
  end)
end)

describe("help(sys), help(tr), help(lin), help(sw): the object you hold", function()
  -- The lines of a block of help text: from the line `title` to the next blank line.
  local function block(text, title)
    local at = assert(text:find("\n" .. title .. "\n", 1, true), ("no block '%s' in:\n%s"):format(title, text))
    return text:sub(at + 1):match("^(.-)\n\n") or text:sub(at + 1)
  end
  local function documents(b, name)
    return b:find("\n  " .. name:gsub("%p", "%%%0") .. "[ \n]") ~= nil
  end
  local function check(obj, prefix, groups)
    local text = nz.help(obj, { quiet = true })
    assert.falsy(text:find("^no help"), text)
    assert.truthy(text:find("^" .. prefix .. ": "), text)
    for line in text:gmatch("[^\n]+") do assert(utf8.len(line) <= 80, ("help(%s): %s"):format(prefix, line)) end
    local fields = block(text, "Fields")
    for key in pairs(obj) do
      if type(key) == "string" and key:sub(1, 1) ~= "_" then
        assert(documents(fields, prefix .. "." .. key), ("help(%s) does not document %s.%s:\n%s"):format(prefix, prefix, key, fields))
      end
    end
    for title, list in pairs(groups or {}) do
      local b = block(text, title)
      for _, t in ipairs(list) do
        for key in pairs(t) do
          assert(documents(b, "." .. key), ("help(%s) does not document .%s under '%s':\n%s"):format(prefix, key, title, b))
        end
      end
    end
    local methods = block(text, ("Methods (%s:NAME(...); help(%s.NAME) explains one)"):format(prefix, prefix))
    local class = getmetatable(obj)
    for name, f in pairs(class) do
      if type(f) == "function" and not name:match("^__") then
        assert(documents(methods, name), ("help(%s) lacks the method %s:\n%s"):format(prefix, name, methods))
      end
    end
    for name in methods:gmatch("\n  ([%w_]+) ") do
      assert(type(class[name]) == "function", ("help(%s) lists %s, which is no method"):format(prefix, name))
    end
  end

  local T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end
  it("a system: plain, a scene, constrained, in Lua, parametric, a Jacobi-Whittaker path", function()
    local kepler = nz.system{ name = "Kepler", coords = { "r", "phi" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + q[1] ^ 2 * qd[2] ^ 2) end, V = function(t, q) return -1 / q[1] end }
    local scene = nz.scene{ name = "pendulum", coords = { "th" },
      bodies = { { name = "bob", mass = 1, pos = function(t, q) return { nz.sin(q[1]), -nz.cos(q[1]), 0 } end } },
      effects = { nz.effects.gravity{ g = { 0, -9.81, 0 } } } }
    local sleigh = nz.system{ name = "sleigh", coords = { "x", "y", "th" }, compile = false, sample = { q = { 0, 0, 0.3 } },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
      constraints = { function(t, q, qd) return -qd[1] * nz.sin(q[3]) + qd[2] * nz.cos(q[3]) end } }
    sleigh:rule()
    local ball = nz.system{ name = "ball", coords = { "x", "y" }, T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      constraints = { nz.unilateral(function(t, q) return q[2] end, { name = "floor", mu = 0.3, slip = function(t, q, qd) return qd[1] end }) } }
    for _, sys in ipairs{ kepler, scene, sleigh, kepler:parametric{}, kepler:jacobi_whittaker{ h = -0.5, independent = "phi" }, ball } do
      check(sys, "sys")
    end
  end)
  it("a trajectory: events, monitors, projection, levels above q'', the top level's root, taylor", function()
    local pend = nz.system{ name = "pendulum", coords = { "th" },
      T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end, V = function(t, q) return -9.81 * nz.cos(q[1]) end }
    local trs = {
      pend:simulate{ q0 = { 1 }, t1 = 2, monitors = { energy = true },
        events = { { name = "th=0", f = function(t, q) return q[1] end, direction = -1 } } },
      pend:simulate{ q0 = { 1 }, t1 = 2, method = "taylor", events = { { f = function(t, q) return q[1] end, stop = true } } },
      pend:simulate{ q0 = { 1 }, t1 = 1, step = 0.01, method = "rk4" },
    }
    local W = 4
    local hoop = nz.system{ name = "driven hoop", coords = { "th", "ph" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + nz.sin(q[1]) ^ 2 * qd[2] ^ 2) end,
      V = function(t, q) return -9.81 * nz.cos(q[1]) end, constraints = { function(t, q) return q[2] - W * t end } }
    trs[#trs + 1] = hoop:simulate{ q0 = { 0.7, 0 }, qd0 = { 0.3, W }, t1 = 1, project = true, monitors = { energy = true, work = true } }
    local servo = nz.system{ name = "servo4", coords = { "x", "y" }, params = { a = 1 },
      T = T, constraints = { function(t, q, qd, qdd, qddd, q4d, params) return q4d[1] + 2 * q4d[2] - params.a * nz.cos(t) end } }
    local q, qd, rep = servo:project(0, { 0, 0 }, { 0, 0 }, { qdd = { 0, 0 }, q3d = { 0, 0 } })
    trs[#trs + 1] = servo:simulate{ q0 = q, qd0 = qd, qdd0 = rep.qdd, q3d0 = rep.q3d, t1 = 0.2 }
    local top = nz.system{ name = "top", coords = { "x", "y" }, T = T, Q = function() return { 0.7, -0.4 } end,
      constraints = { function(t, q, qd, qdd, qddd) return qddd[1] ^ 2 + qddd[2] ^ 2 - 2 end } }
    trs[#trs + 1] = top:simulate{ q0 = { 0.2, -0.1 }, qd0 = { 0.4, -0.5 }, qdd0 = { 0.3, -0.2 }, t1 = 0.2,
      guess = { lambda = { 1 } } }
    -- unilateral contacts: a ball bouncing and sliding to a stop, its events of every kind
    local ball = nz.system{ name = "ball", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end, V = function(t, q) return 9.81 * q[2] end,
      constraints = { nz.unilateral(function(t, q) return q[2] end, { name = "floor", e = 0.5, mu = 0.3,
        slip = function(t, q, qd) return qd[1] end }) } }
    trs[#trs + 1] = ball:simulate{ q0 = { 0, 0.3 }, qd0 = { 2, 0 }, t1 = 2 }
    assert(trs[#trs].contacts and #trs[#trs].events >= 3)
    local stats, events = {}, {}
    for _, tr in ipairs(trs) do
      check(tr, "tr")
      stats[#stats + 1] = tr.stats
      for _, e in ipairs(tr.events) do events[#events + 1] = e end
    end
    assert(#events > 0 and trs[4].projections and trs[5].higher and trs[6].top and trs[6].branch and trs[2].message)
    check(trs[1], "tr", { ["The run's statistics, tr.stats"] = stats, ["Each event crossing, tr.events[e]"] = events })
  end)
  it("a linearization and its modes, a sweep, its rows and its changes of stability", function()
    local A, C, mt, l = 0.02, 0.008, 0.5, 0.04
    local top = nz.system{ name = "top", coords = { "al", "be", "ga" },
      T = function(t, q, qd)
        return 0.5 * A * ((qd[1] * nz.cos(q[2])) ^ 2 + qd[2] ^ 2) + 0.5 * C * (qd[3] + qd[1] * nz.sin(q[2])) ^ 2
      end,
      V = function(t, q) return mt * 9.81 * l * nz.cos(q[1]) * nz.cos(q[2]) end }
    local at = function(n) return { q = { 0, 0, 0 }, qd = { 0, 0, n }, coords = { "al", "be" }, hold = { "ga" } } end
    local lin = top:linearize(at(60))
    lin:eigenvalues()
    check(lin, "lin", { ["Each mode, lin:modes()[m]"] = lin:modes() })
    local cart = nz.system{ name = "cartesian", coords = { "x", "y" }, T = T, V = function(t, q) return 9.81 * q[2] end,
      constraints = { function(t, q) return q[1] ^ 2 + q[2] ^ 2 - 1 end } }
    check(cart:linearize{ q = { 0, -1 } }, "lin")
    local sw = top:eigen_sweep{ parameter = "n", values = { 0, 10, 20, 30 }, at = at }
    check(sw, "sw", { ["Each value, sw.rows[i]"] = sw.rows, ["Each change of stability, sw.crossings[c]"] = sw.crossings })
  end)
  it("help(\"tr\") and the others without one, and help() says so", function()
    for _, p in ipairs{ "sys", "tr", "lin", "sw" } do
      assert.truthy(nz.help(p, { quiet = true }):find("^" .. p .. ": .-\nFields\n"), p)
    end
    assert.truthy(nz.help(nil, { quiet = true }):gsub("%s+", " "):find("help(sys), help(tr), help(lin), help(sw): what", 1, true))
  end)
end)

describe("help(nz.special.elljac)", function()
  it("says that elljac takes the parameter m = k^2 where ellint_K takes the modulus k, as they do", function()
    local text = nz.help(nz.special.elljac, { quiet = true })
    assert.truthy(text:find("m = k^2", 1, true), text)
    assert.truthy(text:find("ellint_K(k)      K(k), the modulus k", 1, true), text)
    -- what it says, checked: sn(K(k) | k^2) = 1 and cn = 0 (a quarter period), for k = 0.6
    local k = 0.6
    local sn, cn, dn = nz.special.elljac(nz.special.ellint_K(k), k * k)
    assert(math.abs(sn - 1) < 1e-14 and math.abs(cn) < 1e-7 and math.abs(dn - math.sqrt(1 - k * k)) < 1e-14, sn)
    -- and the pendulum's closed form it gives: th(t) from th(0) = a at rest, against the motion integrated
    local a, g = 2.0, 9.81
    local pend = nz.system{ name = "pendulum", coords = { "th" },
      T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end, V = function(t, q) return -g * nz.cos(q[1]) end }
    local tr = pend:simulate{ q0 = { a }, t1 = 1, dt = 0.25 }
    local kk = math.sin(a / 2)
    for i, t in ipairs(tr.t) do
      local s = nz.special.elljac(nz.special.ellint_K(kk) - t * math.sqrt(g), kk * kk)
      assert(math.abs(tr.q[i][1] - 2 * math.asin(kk * s)) < 1e-9, ("t = %g: %.12g against %.12g"):format(t, tr.q[i][1], 2 * math.asin(kk * s)))
    end
  end)
end)
