"""How near a real-time stamp must be to the system clock's reading for the tests.

servolab stamps from one fixed offset per process (``servolab.clock.epoch_offset``: one
source, so stamps never jump). When NTP steps the system clock after a process fixed its
offset, ``time.time()`` moves and the stamps do not: a clean-clone run saw 2.1 s. The tests
check that a stamp is today's time, not 1970 + uptime, so a minute is the bound."""

#: s between a real-time stamp and ``time.time()`` that the tests accept
TODAY_S = 60.0
