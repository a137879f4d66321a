"""The library's settings objects take any value a caller might pass (NaN, infinities, huge
and negative numbers, text, None, booleans, containers): ``validate()`` accepts it or raises a
SonoluxError naming the setting, never another exception. The same for the look-ups of a
field (cell_at, impulse_response, paper_filters)."""

from __future__ import annotations

import dataclasses

import pytest
from hypothesis import given
from hypothesis import strategies as st

from sonolux.auralize.offline import AuralizeSettings
from sonolux.auralize.to_file import Listening, Output
from sonolux.errors import SonoluxError
from sonolux.fieldfile import open_field
from sonolux.light.options import LightOptions
from sonolux.light.view import ViewSettings
from sonolux.sound.options import SoundOptions
from sonolux.web.options import WebExportOptions

ANY = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                st.integers(min_value=-(10**30), max_value=10**30), st.text(max_size=4),
                st.none(), st.booleans(), st.lists(st.integers(), max_size=3),
                st.tuples(st.floats(), st.floats()))
SETTINGS = [AuralizeSettings, Output, Listening, LightOptions, ViewSettings, SoundOptions,
            WebExportOptions]


@pytest.mark.parametrize("cls", SETTINGS, ids=lambda c: c.__name__)
@given(data=st.data())
def test_any_value_of_any_setting_validates_or_is_named(cls, data):
    fields = [f.name for f in dataclasses.fields(cls)]
    name = data.draw(st.sampled_from(fields))
    value = data.draw(ANY)
    try:
        cls(**{name: value}).validate()
    except SonoluxError as exc:
        assert "\n" not in str(exc) and str(exc)


@given(x=ANY, y=ANY, receiver=ANY, seed=ANY, length=ANY)
def test_field_lookups_answer_or_name_the_argument(field_file, x, y, receiver, seed, length):
    field = open_field(field_file)
    for call in (lambda: field.cell_at(x, y), lambda: field.impulse_response(receiver, seed=seed),
                 lambda: field.paper_filters(receiver, length if isinstance(length, int)
                                             and length < 10_000 else length)):
        try:
            call()
        except SonoluxError as exc:
            assert str(exc)
