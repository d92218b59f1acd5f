-- wrk script: each connection waits between requests, so that connections * 1000 / PACE_MS
-- requests per second are offered (wrk's latency figures do not include the wait).
--   PACE_GAPS=fixed (default): every wait is PACE_MS milliseconds. wrk starts every
--     connection at once, so they send in step: with many connections the load arrives in
--     bursts (256 connections at 51 ms: up to 256 requests within a millisecond or two).
--   PACE_GAPS=exponential: waits drawn from an exponential distribution of mean PACE_MS
--     (rounded to wrk's milliseconds), so each connection is a Poisson source and the
--     connections stay independent, as separate clients are.
local pace = tonumber(os.getenv("PACE_MS") or "2")
local exponential = os.getenv("PACE_GAPS") == "exponential"

function init(args)
  -- Each thread has a Lua state of its own: seed each differently (a table's address).
  local address = tonumber(tostring({}):match("0x(%x+)") or "0", 16) or 0
  math.randomseed(os.time() + address % 1000003)
end

function delay()
  if exponential then
    return math.floor(-pace * math.log(1 - math.random()) + 0.5)
  end
  return pace
end
