-- A million jet operations in a loop: the garbage collector must keep memory
-- bounded, and LeakSanitizer (sanitized build) must find nothing at exit.
local x = nz.jet{ 0.7, 0.3, -0.2, order = 4, tangents = { { 1, 0.5 } } }
local acc = 0
local peak = 0
for i = 1, 250000 do
  local y = nz.sin(x) * x + 1 / (x + i)       -- four operations
  acc = acc + y:value()
  if i % 50000 == 0 then peak = math.max(peak, collectgarbage("count")) end
end
-- A jet of this shape is well under 1 KiB: 250000 live ones would be 100s of
-- MiB; a bounded collector keeps the heap within a few MiB.
assert(peak < 16 * 1024, ("heap grew to %.0f KiB during the loop"):format(peak))
print(("memory loop: 1000000 operations, peak heap %.0f KiB, checksum %.6f"):format(peak, acc))
