-- nz/base/session.lua - what a session keeps between calls: the last run's
-- trajectory (nz.last), set by the runs (nz/motion/simulate.lua) when they
-- stop or fail, read through the face (init.lua makes nz.last this field),
-- so that no lower floor reaches up to the face to keep it.
return { last = nil }
