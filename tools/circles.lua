-- circles.lua - the circles of a directed graph, for the checks of the
-- code's structure (tools/requires.lua: requires between Lua modules;
-- tools/shape.lua: includes between C files).
--
--   circles(names, targets, what) -> { "a circle of WHAT: a -> b -> a", ... }
--
-- names: the nodes in the order to start from; targets(name): the nodes it
-- points at, in order (nil or {} for none), of which only nodes in names
-- are followed.  A depth-first search; each circle is said once, by the
-- members in the order the search met them.
return function(names, targets, what)
  local known = {}
  for _, n in ipairs(names) do known[n] = true end
  local bad, state, stack, said = {}, {}, {}, {}
  local function visit(name)
    state[name] = 1
    stack[#stack + 1] = name
    for _, t in ipairs(targets(name) or {}) do
      if state[t] == 1 then
        local circle, from = {}, nil
        for i, s in ipairs(stack) do if s == t then from = i end end
        for i = from, #stack do circle[#circle + 1] = stack[i] end
        local key = table.concat(circle, " ")
        if not said[key] then
          said[key] = true
          bad[#bad + 1] = ("a circle of %s: %s -> %s"):format(what, table.concat(circle, " -> "), t)
        end
      elseif not state[t] and known[t] then
        visit(t)
      end
    end
    stack[#stack] = nil
    state[name] = 2
  end
  for _, n in ipairs(names) do if not state[n] then visit(n) end end
  return bad
end
