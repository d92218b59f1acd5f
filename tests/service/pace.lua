-- wrk script: each connection waits PACE_MS milliseconds between requests, so that
-- connections * 1000 / PACE_MS requests per second are offered (an open-loop-like rate;
-- wrk's latency figures do not include the wait).
local pace = tonumber(os.getenv("PACE_MS") or "2")
function delay()
  return pace
end
