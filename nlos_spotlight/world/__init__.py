"""The synthetic world: procedural rooms and hidden people (DESIGN section 7)."""
