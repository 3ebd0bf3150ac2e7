"""Channels that follow the beam: the gateware units (docs/beam_following.md;
the rule ``rast.model.contract.follow``)."""
