"""A recording's site argument (``rinscal.nav.recording.parse_site``): degrees and metres in,
radians and metres out, each bad value refused naming the argument (the CLI translates it
to --site)."""

from __future__ import annotations

import math

import pytest

from rinscal.errors import ConfigError
from rinscal.nav.recording import parse_site


def test_a_site_is_read_in_degrees_and_metres() -> None:
    lat, lon, h = parse_site(" 34.75, -117.5 ,12.5")
    assert (lat, lon, h) == (math.radians(34.75), math.radians(-117.5), 12.5)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("34.75,-117.5", "is not LAT,LON,HEIGHT"),
        ("34.75,-117.5,1,2", "is not LAT,LON,HEIGHT"),
        ("north,-117.5,0", "is not LAT,LON,HEIGHT"),
        ("nan,0,0", "non-finite"),
        ("90.5,0,0", "latitude 90.5° lies outside ±90°"),
    ],
)
def test_a_bad_site_is_refused_naming_the_argument(text: str, words: str) -> None:
    with pytest.raises(ConfigError, match="site=") as err:  # the CLI says --site
        parse_site(text)
    assert words in str(err.value)
