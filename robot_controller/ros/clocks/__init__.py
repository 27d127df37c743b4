"""The clocks that step the world block (``blocks.world``) in the graph, one chosen per run: the wall clock
(``wall``), the paced world (``paced``: sim time at real-time pace, the default ``run``) and sim time as fast as
the graph goes (``stepped``). Each steps the world through its methods only, and publishes through its host's
outlets (``host``)."""
