"""riverbridge: navigation."""
