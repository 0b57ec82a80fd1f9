-- jet_lua.lua - jet arithmetic through Lua (nz module): operations per
-- second for mul, div, sin, exp at orders 1, 4, 16, 64, 0 and 4 tangents.
-- Includes the cost of the Lua call and of one userdata per result.
local nz = rawget(_G, "nz") or require "nz"
local clock = os.clock

local ops = {
  { "mul", function(a, b) return a * b end },
  { "div", function(a, b) return a / b end },
  { "sin", function(a) return nz.sin(a) end },
  { "exp", function(a) return nz.exp(a) end },
}

local function rate(f, K, D)
  local a = D > 0 and nz.jet(0.7, K, 1, D) or nz.jet(0.7, K)
  local b = D > 1 and nz.jet(1.3, K, 2, D) or nz.jet(1.3, K)
  local n, t0 = 0, clock()
  local t
  repeat
    for _ = 1, 64 do f(a, b) end
    n = n + 64
    t = clock() - t0
  until t >= 0.2
  return n / t
end

print("Jet operations through Lua (million operations per second)")
local head = ("%6s %9s"):format("order", "tangents")
for _, op in ipairs(ops) do head = head .. (" %9s"):format(op[1]) end
print(head)
for _, K in ipairs{ 1, 4, 16, 64 } do
  for _, D in ipairs{ 0, 4 } do
    local line = ("%6d %9d"):format(K, D)
    for _, op in ipairs(ops) do line = line .. (" %9.3f"):format(rate(op[2], K, D) / 1e6) end
    print(line)
  end
end
