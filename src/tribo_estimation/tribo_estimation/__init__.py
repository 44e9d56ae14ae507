"""tribo_estimation package."""
