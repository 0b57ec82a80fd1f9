-- tests/fuzz/run.lua - the differential fuzzer from the command line (make
-- fuzz): random systems recorded against the same systems in Lua.
--   build/nzlua tests/fuzz/run.lua [COUNT [SEED]]
-- COUNT systems (default 500) from SEED (default: the clock; printed, so a
-- run can be repeated).  Prints each finding with the system's source and
-- exits 1 if there is one.
package.path = "./?.lua;" .. package.path
local compare = require "tests.fuzz.compare"

local count = tonumber(arg and arg[1]) or 500
local seed = tonumber(arg and arg[2]) or os.time()
io.write(("fuzz: %d random systems from seed %d (repeat: build/nzlua tests/fuzz/run.lua %d %d)\n")
  :format(count, seed, count, seed))
local clock = os.clock()
local findings, comparisons, tried, refused = compare.run(seed, count, {
  progress = function(i, nf)
    if i % 1000 == 0 and i < count then
      io.write(("fuzz: %d systems, %d findings so far\n"):format(i, nf))
      io.stdout:flush()
    end
  end })
for _, f in ipairs(findings) do io.write(compare.describe(f), "\n\n") end
io.write(("fuzz: %d systems (%d refused by nz.system in both forms), %d comparisons (%d where both answered), "
  .. "%d findings, %.1f s\n"):format(tried, refused, comparisons, compare.answered, #findings, os.clock() - clock))
os.exit(#findings == 0 and 0 or 1)
