-- tutorial_spec.lua - docs/tutorial.md never goes stale: its lua blocks run
-- in order in one nzlua process, and every line of its output blocks
-- appears, in order, in what they print.
local h = require "tests.helpers"

describe("docs/tutorial.md", function()
  it("runs every command and prints what it shows", function()
    local text = assert(io.open("docs/tutorial.md")):read("a")
    local code, expected = {}, {}
    for kind, body in text:gmatch("```(%w+)\n(.-)```") do
      if kind == "lua" then code[#code + 1] = body
      elseif kind == "output" then
        for line in body:gmatch("[^\n]+") do expected[#expected + 1] = line end
      end
    end
    assert(#code >= 6 and #expected >= 6, "the tutorial lost its blocks")
    local script = os.tmpname()
    local f = assert(io.open(script, "w"))
    f:write(table.concat(code, "\n"))
    f:close()
    local rc, out, err = h.run(h.nzlua .. " " .. script)
    os.remove(script)
    assert(rc == 0, "the tutorial's code failed:\n" .. err)
    local at = 1
    for _, line in ipairs(expected) do
      local a, b = out:find(line, at, true)
      assert(a, ("the tutorial shows %q, which its code no longer prints (after position %d):\n%s"):format(line, at, out))
      at = b + 1
    end
  end)
end)
