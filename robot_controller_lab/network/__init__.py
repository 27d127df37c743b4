"""The loop across two hosts, emulated on one machine: two network namespaces
joined by a veth pair (``netns``), the conditions of the network bench and
their scoring (``conditions``), its report (``report``) and the bench that runs
them (``bench``, ``robot-controller network``)."""
