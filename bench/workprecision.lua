-- workprecision.lua - what accuracy costs in time on the standard problems
-- (bench/problems.lua): a table per problem from nz.workprecision.
--   nzlua bench/workprecision.lua [problem ...] [--svg DIR]
-- With --svg, each diagram is also written to DIR/workprecision-NAME.svg.
package.path = "bench/?.lua;" .. package.path
local problems = require "problems"
local nz = rawget(_G, "nz") or require "nz"

local wanted, svgdir = {}, nil
local i = 1
while arg and arg[i] do
  if arg[i] == "--svg" then svgdir = arg[i + 1]; i = i + 1 else wanted[#wanted + 1] = arg[i] end
  i = i + 1
end
if #wanted == 0 then wanted = problems.order end

for _, name in ipairs(wanted) do
  local p = assert(problems[name], "no problem " .. name)()
  local o = { methods = { "rk4", "rkf45", "rkck", "rk8pd", "rk4imp", "bsimp", "msadams", "msbdf", "taylor" },
    tols = { 1e-4, 1e-6, 1e-8, 1e-10 }, reference = p.reference }
  for k, v in pairs(p.start) do o[k] = v end
  local rows = nz.workprecision(p.sys, o)
  if svgdir then
    require("nz.workprecision").diagram(rows, { file = ("%s/workprecision-%s.svg"):format(svgdir, name),
      title = "work-precision: " .. p.sys.name })
  end
  print()
end
