"""Placeholder: replaced by the validation report module."""


def validate(*args, **kwargs):
    raise NotImplementedError("validate is not implemented yet")


class ValidationReport:
    pass
