-- workprecision.lua - what accuracy costs in time on the standard problems
-- (bench/problems.lua): a table per problem from nz.workprecision, with its
-- procedure (nz/analysis/workprecision.lua): one evaluator, a warm-up run per
-- method not timed, each point's processor time the minimum of at least 3
-- runs that spend the budget.
--   nzlua bench/workprecision.lua [problem ...] [--svg DIR] [--x time|nfev|steps] [--budget SECONDS]
-- With --svg, each diagram is also written to DIR/workprecision-NAME.svg
-- (docs/workprecision-kepler.svg is `--svg docs kepler`).
package.path = "bench/?.lua;" .. package.path
local problems = require "problems"
local nz = rawget(_G, "nz") or require "nz"

local wanted, svgdir, x, budget = {}, nil, nil, nil
local i = 1
while arg and arg[i] do
  if arg[i] == "--svg" then svgdir = arg[i + 1]; i = i + 1
  elseif arg[i] == "--x" then x = arg[i + 1]; i = i + 1
  elseif arg[i] == "--budget" then budget = tonumber(arg[i + 1]); i = i + 1
  else wanted[#wanted + 1] = arg[i] end
  i = i + 1
end
if #wanted == 0 then wanted = problems.order end

for _, name in ipairs(wanted) do
  local p = assert(problems[name], "no problem " .. name)()
  local o = { methods = { "rk4", "rkf45", "rkck", "rk8pd", "rk4imp", "bsimp", "msadams", "msbdf", "taylor" },
    tols = { 1e-4, 1e-6, 1e-8, 1e-10 }, reference = p.reference, x = x, budget = budget,
    plot = svgdir and ("%s/workprecision-%s.svg"):format(svgdir, name) or nil }
  for k, v in pairs(p.start) do o[k] = v end
  nz.workprecision(p.sys, o)
  print()
end
