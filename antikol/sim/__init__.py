"""The project's own traffic simulator (routes, driver model, GPS model, true states)."""
