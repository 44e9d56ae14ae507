"""tribo_bringup package."""
