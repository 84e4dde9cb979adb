"""Line styles of the timeline plots: every line distinguishable however many there are."""
from ramensim.evaluation.plots import _line_styles, plot_timelines


def test_fourteen_lines_are_pairwise_distinct():
    labels = [f"{p}, {m}" for p in (1.0, 0.8, 0.6, 0.4, 0.2, 0.05, 0.01) for m in ("ramen", "dinno")]
    colour, style = _line_styles(labels)
    pairs = {(tuple(colour[lb]), style[lb]) for lb in labels}
    assert len(pairs) == len(labels)
    # the method is told by the line style, the condition by the colour
    assert style["1.0, ramen"] == style["0.01, ramen"] != style["1.0, dinno"]
    assert tuple(colour["1.0, ramen"]) == tuple(colour["1.0, dinno"])


def test_many_conditions_use_a_sequential_map():
    labels = [f"c{k}" for k in range(12)]
    colour, style = _line_styles(labels)
    assert len({tuple(c) for c in colour.values()}) == 12
    fig = plot_timelines({lb: [(0.0, 1.0, 0.1), (1.0, 0.5, 0.1)] for lb in labels}, "consensus_error")
    assert len(fig.axes[0].get_lines()) == 12
