"""tribo_nvct package."""
