local function deep()
  return nz.log(-1)
end
local x = 1
deep()
