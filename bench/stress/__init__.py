"""`make stress`: the attacks of issue #19 against a running `openair serve`, with verdicts.

Each attack is what an operator of a shared lab server fears (a subscriber that never reads,
retrieves of everything, large posts, connection floods, frames that never end, half-sent HTTP
requests). For each, `python -m bench.stress` prints held / degraded / broken with its figures,
the server's peak RSS against the budget it was configured with, and a canary client's p99
round trip during the attack as a ratio to the quiet canary of the same run. Never part of
`make test`; the fast attacks have regression tests in tests/server_io and tests/monitor.
"""
