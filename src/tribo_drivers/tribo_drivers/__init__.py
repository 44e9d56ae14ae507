"""tribo_drivers package."""
