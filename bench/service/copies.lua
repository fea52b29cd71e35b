-- wrk script: POST /v1/assets/ASSET/copies with a new recipient name per request, so every
-- request records a name (the service's slowest path for a warm asset). Set by environment:
-- MESHMARK_TOKEN (the bearer token), MESHMARK_ASSET (URL-encoded asset id), MESHMARK_PREFIX
-- (names' prefix, so runs do not collide), MESHMARK_FORMAT (optional: glb, ply, ...).
local threads = 0
function setup(thread)
  thread:set("tid", threads)
  threads = threads + 1
end

function init(args)
  counter = 0
  token = os.getenv("MESHMARK_TOKEN")
  asset = os.getenv("MESHMARK_ASSET")
  prefix = os.getenv("MESHMARK_PREFIX") or "w"
  format = os.getenv("MESHMARK_FORMAT")
end

function request()
  counter = counter + 1
  local fmt = ""
  if format and format ~= "" then fmt = string.format(',"format":"%s"', format) end
  local body = string.format('{"recipient":"%s-%d-%d"%s}', prefix, tid, counter, fmt)
  return wrk.format("POST", "/v1/assets/" .. asset .. "/copies",
    {["Authorization"] = "Bearer " .. token, ["Content-Type"] = "application/json"}, body)
end

function done(summary, latency, requests)
  io.write(string.format("RESULT requests=%d errors_status=%d errors_connect=%d errors_read=%d errors_timeout=%d " ..
    "duration_s=%.3f p50_ms=%.2f p90_ms=%.2f p99_ms=%.2f max_ms=%.2f\n",
    summary.requests, summary.errors.status, summary.errors.connect, summary.errors.read, summary.errors.timeout,
    summary.duration / 1e6, latency:percentile(50) / 1e3, latency:percentile(90) / 1e3,
    latency:percentile(99) / 1e3, latency.max / 1e3))
end
