"""fasttrack.stonesoup.gater: associations through drop-in ``DistanceGater``s (and the
``Euclidean`` measure) equal Stone Soup's, on the vectorised path."""
import pytest

pytest.importorskip("stonesoup")
from stonesoup import measures as ss_measures  # noqa: E402
from stonesoup.dataassociator import neighbour as ss_neighbour  # noqa: E402

import fasttrack.stonesoup as fss  # noqa: E402
from test_stonesoup_dataassociator import (DT, T0, assert_same_hypothesis,  # noqa: E402
                                           associate_both, hypothesiser,
                                           no_stone_soup_association, scenario)


def test_euclidean_measure_and_distance_gater():
    tracks, detections = scenario(60, spacing=8.0, seed=4)
    associate_both("NearestNeighbour", "distance", tracks, detections, missed_distance=3,
                   measure=None)
    ours = fss.NearestNeighbour(hypothesiser("ft", measure=ss_measures.Euclidean(),
                                             missed_distance=3))
    theirs = ss_neighbour.NearestNeighbour(hypothesiser("ss", measure=ss_measures.Euclidean(),
                                                        missed_distance=3))
    with no_stone_soup_association():
        a = ours.associate(tracks, detections, T0 + DT)
    b = theirs.associate(tracks, detections, T0 + DT)
    for track in tracks:
        assert_same_hypothesis(a[track], b[track])
    associate_both("GNNWith2DAssignment", "distance", tracks, detections, missed_distance=10,
                   gate=2.5)
