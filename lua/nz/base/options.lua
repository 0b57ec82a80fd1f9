-- nz/base/options.lua - the check every method makes of its option table: an
-- unknown key is refused, never ignored (a misspelled `coord = {...}` that
-- was silently dropped gave a linearization about another state), with
-- the accepted names and the nearest one when the key looks like a typo.
local M = {}

-- Edit distance (insertions, deletions, substitutions, and swaps of two
-- neighbours: "hodl" is one typo from "hold"), for the suggestion.
local function distance(a, b)
  local d = {}
  for i = 0, #a do d[i] = { [0] = i } end
  for j = 0, #b do d[0][j] = j end
  for i = 1, #a do
    for j = 1, #b do
      local cost = a:sub(i, i) == b:sub(j, j) and 0 or 1
      d[i][j] = math.min(d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost)
      if i > 1 and j > 1 and a:sub(i, i) == b:sub(j - 1, j - 1) and a:sub(i - 1, i - 1) == b:sub(j, j) then
        d[i][j] = math.min(d[i][j], d[i - 2][j - 2] + 1)
      end
    end
  end
  return d[#a][#b]
end

-- The accepted name nearest to key, when it is near enough to be a typo.
function M.nearest(key, names)
  local best, bestd
  for _, n in ipairs(names) do
    local d = distance(key, n)
    if not bestd or d < bestd then best, bestd = n, d end
  end
  if bestd and bestd <= math.max(1, #key // 3) then return best end
end

-- The options each method accepts, by the call as help writes it
-- ("tr:plot", "nz.sweep"): the names, and a pattern function for keys
-- accepted by shape (simulate's q3d0, q4d0, ...).  tests/help_spec.lua
-- compares them with the options help lists for that call, so that a
-- signature in help says what the code accepts.
M.accepted = {}

-- Declare the options of `call`; returns names (to be checked with M.check).
function M.declare(call, names, accept)
  M.accepted[call] = { names = names, accept = accept }
  return names
end

-- Refuse any key of opts not in names: a list (in the order the message
-- gives them) or a set {name = anything} (listed sorted; names starting
-- with "_" are internal and not listed).  fail(fmt, ...) raises the
-- caller's error; accept(key), when given, admits keys of a pattern (the
-- levels of simulate's qNd0).
function M.check(opts, names, fail, accept)
  local known = {}
  if #names == 0 and next(names) ~= nil then   -- a set
    known = names
    names = {}
    for key in pairs(known) do if type(key) == "string" and key:sub(1, 1) ~= "_" then names[#names + 1] = key end end
    table.sort(names)
  else
    for _, n in ipairs(names) do known[n] = true end
  end
  for key in pairs(opts) do
    if known[key] == nil and not (accept and accept(key)) then
      local near = type(key) == "string" and M.nearest(key, names)
      fail("unknown option '%s'%s (options: %s)", tostring(key), near and (" (did you mean '" .. near .. "'?)") or "",
        table.concat(names, ", "))
    end
  end
end

return M
