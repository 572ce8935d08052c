"""The shipped scenario files: data only, read through ``flatland_ma.list_scenarios()`` and
``load_scenario(NAME)``. Installed as the package ``flatland_ma.scenarios`` (see
``pyproject.toml``) so that ``importlib.resources`` finds them in any install."""
