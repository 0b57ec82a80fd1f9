-- tutorial_spec.lua - docs/tutorial.md never goes stale: its lua blocks run
-- in order in one nzlua process, saved as a script and typed at the prompt
-- (where each complete statement is a chunk of its own, so a `local` does
-- not outlive its line), and every line of its output blocks appears, in
-- order, in what they print.  The lua blocks of the README and docs/ are
-- meant for the prompt too: none declares a local at its top level.
local h = require "tests.helpers"

-- The bodies of the ```kind blocks of a markdown file, in order.
local function blocks(path, want)
  local text = assert(h.slurp(path), path)
  local out = {}
  for kind, body in text:gmatch("```(%w+)\n(.-)```") do
    if kind == want then out[#out + 1] = body end
  end
  return out
end

-- Every line of `expected` in `out`, in order.
local function in_order(expected, out, how)
  local at = 1
  for _, line in ipairs(expected) do
    local a, b = out:find(line, at, true)
    assert(a, ("the tutorial shows %q, which its code %s no longer prints (after position %d):\n%s"):format(line, how, at, out))
    at = b + 1
  end
end

describe("docs/tutorial.md", function()
  local code, expected = blocks("docs/tutorial.md", "lua"), {}
  for _, body in ipairs(blocks("docs/tutorial.md", "output")) do
    for line in body:gmatch("[^\n]+") do expected[#expected + 1] = line end
  end
  it("has its blocks", function()
    assert(#code >= 6 and #expected >= 6, "the tutorial lost its blocks")
  end)
  it("runs every command as a script and prints what it shows", function()
    local script = os.tmpname()
    local f = assert(io.open(script, "w"))
    f:write(table.concat(code, "\n"))
    f:close()
    local rc, out, err = h.run(h.nzlua .. " " .. script)
    os.remove(script)
    assert(rc == 0, "the tutorial's code failed:\n" .. err)
    in_order(expected, out, "run as a script")
  end)
  it("leaves no file behind: every name it takes from os.tmpname is removed", function()
    local script = os.tmpname()
    local f = assert(io.open(script, "w"))
    f:write("local made, tmpname = {}, os.tmpname\n",
      "os.tmpname = function() local n = tmpname(); made[#made + 1] = n; return n end\n",
      table.concat(code, "\n"),
      "\nfor _, n in ipairs(made) do local left = io.open(n); if left then left:close(); print('LEFT ' .. n) end end\n",
      "print(('tmpnames %d'):format(#made))\n")
    f:close()
    local rc, out, err = h.run(h.nzlua .. " " .. script)
    os.remove(script)
    assert(rc == 0, err)
    assert.falsy(out:find("LEFT ", 1, true), out)
    assert.truthy(out:find("tmpnames [1-9]"), out)
  end)
  it("prints the bouncing ball's accumulation time, t1 (1 + e)/(1 - e) = 3 sqrt(2/g), and the cradle's outcomes", function()
    local text = assert(h.slurp("docs/tutorial.md"))
    local shown = tonumber(text:match("```output\n[^`]-accumulating at t = ([%d.]+)"))
    assert(shown and math.abs(shown - 3 * math.sqrt(2 / 9.81)) <= 1e-9, "the accumulation shown: " .. tostring(shown))
    -- the simultaneous law (-1/3, 2/3, 2/3) v, and the sequence (0, 0, v) with a gap; v = 1.3
    local v = 1.3
    local a, b, c = text:match("touching:%s+{([-%d.e]+), ([-%d.e]+), ([-%d.e]+)}")
    assert(a and math.abs(a + v / 3) + math.abs(b - 2 * v / 3) + math.abs(c - 2 * v / 3) <= 1e-14, tostring(a))
    a, b, c = text:match("1 mm apart:%s+{([-%d.e]+), ([-%d.e]+), ([-%d.e]+)}")
    assert(a and math.abs(a) + math.abs(b) + math.abs(c - v) <= 1e-14, tostring(a))
  end)
  it("runs every command typed at the nz> prompt, as the page says, and prints what it shows", function()
    -- the session reads the lines from stdin as from the keyboard: each
    -- line a chunk, or the lines up to the end of an incomplete statement
    local rc, out, err = h.run(h.nzlua .. " -i", table.concat(code, "\n") .. "\n")
    assert(rc == 0, "the session failed:\n" .. err)
    -- an error at the prompt is reported on stderr and the session goes on
    assert(err == "", "a command of the tutorial failed at the prompt:\n" .. err)
    in_order(expected, out, "typed at the prompt")
  end)
end)

describe("the lua blocks of the README and docs/", function()
  it("declare no local at their top level (at the prompt it would be gone on the next line)", function()
    local files = { "README.md", "examples/README.md" }
    local p = io.popen("ls docs/*.md")
    for path in p:lines() do files[#files + 1] = path end
    p:close()
    local n = 0
    for _, path in ipairs(files) do
      for _, body in ipairs(blocks(path, "lua")) do
        n = n + 1
        for line in body:gmatch("[^\n]+") do
          assert(not line:match("^local%s"), ("%s: a block meant for the prompt declares a local: %s\n"
            .. "(each line typed at the prompt is a chunk of its own: use a global)"):format(path, line))
        end
      end
    end
    assert(n >= 12, n)
  end)
end)
