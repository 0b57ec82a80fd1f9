-- nz/model/rotations.lua - rotation matrices of numbers or jets, for the rot of
-- rigid bodies: nz.rotations.x(a), .y(a), .z(a), .mul(A, B), and
-- .euler_zxz(psi, theta, phi) = z(psi) x(theta) z(phi) (body to space).
local core = require "nz.core"
local M = {}

function M.x(a) local c, s = core.cos(a), core.sin(a); return { { 1, 0, 0 }, { 0, c, -s }, { 0, s, c } } end
function M.y(a) local c, s = core.cos(a), core.sin(a); return { { c, 0, s }, { 0, 1, 0 }, { -s, 0, c } } end
function M.z(a) local c, s = core.cos(a), core.sin(a); return { { c, -s, 0 }, { s, c, 0 }, { 0, 0, 1 } } end

function M.mul(A, B)
  local C = {}
  for i = 1, 3 do
    C[i] = {}
    for j = 1, 3 do C[i][j] = A[i][1] * B[1][j] + A[i][2] * B[2][j] + A[i][3] * B[3][j] end
  end
  return C
end

function M.euler_zxz(psi, theta, phi) return M.mul(M.mul(M.z(psi), M.x(theta)), M.z(phi)) end

return M
