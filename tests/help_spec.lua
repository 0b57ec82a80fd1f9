-- help_spec.lua - nz.help lists exactly what the module offers.
local h = require "tests.helpers"
local nz = h.nz
local entries = require("nz.help").entries

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
