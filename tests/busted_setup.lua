-- busted_setup.lua - loaded by busted before the specs: seed the random
-- generator so that a failure can be reproduced (the seed is printed).
local seed = tonumber(os.getenv("NZ_TEST_SEED")) or os.time()
math.randomseed(seed)
io.stderr:write(("# random seed %d (set NZ_TEST_SEED to repeat)\n"):format(seed))
