"""Input checks: types, shapes, segments, time stamps, settings, the checked call, errors."""
