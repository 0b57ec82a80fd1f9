-- requires.lua - the Lua half's floors and its require graph.
--
--   lua5.4 tools/requires.lua          the graph as docs/architecture.md
--                                      shows it (markdown)
--   lua5.4 tools/requires.lua --write  the same, written into
--                                      docs/architecture.md's block
--   dofile("tools/requires.lua")       the functions, for tests/layers_spec.lua
--
-- lua/nz/ holds one folder per floor; a module may require modules of its
-- own floor and of the floors below it, never above, and no circle of
-- requires may form (also not through a require written inside a function:
-- every `require "nz.X"` in a file counts).  The face (lua/nz/system.lua,
-- lua/nz/init.lua) sits on top and requires what it attaches.
local M = {}

-- tools/circles.lua, beside this file wherever it is run from.
local circles = dofile((debug.getinfo(1, "S").source:match("^@(.*/)") or "./") .. "circles.lua")

-- Lowest first.
M.FLOORS = { "base", "draw", "model", "motion", "analysis", "presentation", "session", "face" }
M.JOB = {
  base = "options, messages, text, the classes the face fills: no other nz module below them",
  draw = "turning values into what a front-end shows: bundles, plots",
  model = "what a system is: recording, constraints, bodies, effects, scenes, contacts",
  motion = "running it: the stepping loop, trajectories, sweeps",
  analysis = "asking it questions: linearization, stability, time as a coordinate, defects, work-precision, long runs",
  presentation = "the equations as formulas and code, the views of a run",
  session = "the front-ends' shared part: the printer, help, the kernel",
  face = "nz itself: system.lua attaches the methods, init.lua assembles nz",
}

local rank = {}
for i, f in ipairs(M.FLOORS) do rank[f] = i end

local function list(cmd)
  local p = assert(io.popen(cmd))
  local out = {}
  for line in p:lines() do out[#out + 1] = line end
  p:close()
  table.sort(out)
  return out
end

-- The modules a Lua source requires: every `require "name"` or
-- `require("name")` written in its code, at the top or inside a function,
-- read by a small scanner that skips comments and the text of strings (a
-- message that names a module, "require('nz.motion.simulate').MAX_MEMORY",
-- is no require).  `require "nz"` is the face's init.lua.
local function scan_requires(src)
  local found, i, n = {}, 1, #src
  local function skip_long(at)            -- [[ ... ]], [==[ ... ]==] from at: the index after it, or nil
    local eq = src:match("^%[(=*)%[", at)
    if not eq then return nil end
    local _, e = src:find("]" .. eq .. "]", at + #eq + 2, true)
    return (e or n) + 1
  end
  local function skip_string(at)          -- "..." or '...' from at: the index after it
    local q, j = src:sub(at, at), at + 1
    while j <= n do
      local c = src:sub(j, j)
      if c == "\\" then j = j + 2
      elseif c == q or c == "\n" then return j + 1
      else j = j + 1 end
    end
    return j
  end
  while i <= n do
    local c = src:sub(i, i)
    if src:sub(i, i + 1) == "--" then
      i = skip_long(i + 2) or ((src:find("\n", i, true) or n) + 1)
    elseif c == '"' or c == "'" then
      i = skip_string(i)
    elseif c == "[" and skip_long(i) then
      i = skip_long(i)
    elseif c:match("[%a_]") then
      local word = src:match("^[%w_]+", i)
      local before = i > 1 and src:sub(i - 1, i - 1) or ""
      i = i + #word
      if word == "require" and before ~= "." and before ~= ":" then
        local name = src:match("^%s*%(?%s*[\"']([%w_.]+)[\"']", i)
        if name then found[#found + 1] = name == "nz" and "nz.init" or name end
      end
    else
      i = i + 1
    end
  end
  return found
end
M.scan_requires = scan_requires

-- Every module: {name = "nz.model.record", path, floor, requires = {names}}.
function M.modules(root)
  root = root or "."
  local mods = {}
  for _, path in ipairs(list(("cd %s && find lua/nz -name '*.lua'"):format(root))) do
    local rel = path:match("^lua/(.*)%.lua$")
    local name = rel:gsub("/", ".")
    local folder = rel:match("^nz/([%w_]+)/")
    local f = assert(io.open(root .. "/" .. path))
    local src = f:read("a")
    f:close()
    local reqs, seen = {}, {}
    -- (not the C binding nz.core below them all, not the files nzlua
    -- carries (nz.files.*, tools/embed.lua), not the modules of other
    -- libraries)
    for _, r in ipairs(scan_requires(src)) do
      if r:match("^nz%.") and r ~= "nz.core" and not r:match("^nz%.files%.") and r ~= name and not seen[r] then
        seen[r] = true
        reqs[#reqs + 1] = r
      end
    end
    table.sort(reqs)
    mods[#mods + 1] = { name = name, path = path, floor = folder or "face", requires = reqs }
  end
  return mods
end

-- What breaks the rule: a list of messages (empty when the layers hold).
function M.violations(mods)
  local by, bad = {}, {}
  for _, m in ipairs(mods) do by[m.name] = m end
  for _, m in ipairs(mods) do
    if not rank[m.floor] then
      bad[#bad + 1] = ("%s: folder '%s' is not a floor (tools/requires.lua's FLOORS)"):format(m.path, m.floor)
    end
    for _, r in ipairs(m.requires) do
      local t = by[r]
      if not t then
        bad[#bad + 1] = ("%s requires %s, which is no module of lua/nz"):format(m.name, r)
      elseif rank[t.floor] and rank[m.floor] and rank[t.floor] > rank[m.floor] then
        bad[#bad + 1] = ("%s (%s) requires %s (%s), a floor above it"):format(m.name, m.floor, r, t.floor)
      end
    end
  end
  -- circles, each said once by its members
  local names = {}
  for _, m in ipairs(mods) do names[#names + 1] = m.name end
  for _, b in ipairs(circles(names, function(name) return by[name] and by[name].requires end, "requires")) do
    bad[#bad + 1] = b
  end
  return bad
end

-- The graph in markdown: per floor, each module and what it requires.
function M.markdown(mods)
  local out = {}
  for i = #M.FLOORS, 1, -1 do
    local f = M.FLOORS[i]
    out[#out + 1] = ("- **%s** (%s)"):format(f, M.JOB[f])
    for _, m in ipairs(mods) do
      if m.floor == f then
        local short = {}
        for j, r in ipairs(m.requires) do short[j] = r:gsub("^nz%.", "") end
        out[#out + 1] = ("  - `%s` -> %s"):format(m.name:gsub("^nz%.", ""),
          #short > 0 and table.concat(short, ", ") or "(none)")
      end
    end
  end
  return table.concat(out, "\n")
end

-- The page with its block between <!-- requires: begin ... --> and
-- <!-- requires: end --> replaced by the graph.
function M.write(path, graph)
  local f = assert(io.open(path))
  local doc = f:read("a")
  f:close()
  local head, tail = doc:match("^(.-<!%-%- requires: begin[^\n]*%-%->\n).-(\n<!%-%- requires: end %-%->.*)$")
  assert(head, path .. " has no block between <!-- requires: begin --> and <!-- requires: end -->")
  f = assert(io.open(path, "w"))
  f:write(head, graph, tail)
  f:close()
end

if arg and arg[0] and arg[0]:match("requires%.lua$") and not debug.getinfo(3) then
  local graph = M.markdown(M.modules("."))
  if arg[1] == "--write" then M.write(arg[2] or "docs/architecture.md", graph) else print(graph) end
end

return M
