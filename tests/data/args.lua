-- prints what a script sees of its arguments
print("arg0=" .. arg[0], "n=" .. #arg, "first=" .. tostring(arg[1]), "dots=" .. select("#", ...))
print("nz=" .. type(nz), "sin=" .. type(sin), "version=" .. nz.version)
