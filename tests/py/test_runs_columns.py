"""A run's data frames (analysis/runs.py): no column of any channel is
hidden by an attribute of pandas' DataFrame (run["FW_STATE"].flags was
DataFrame.flags, not the FLAG_* bits)."""
import pandas as pd

from analysis import lcmschema, runs


def test_no_column_is_a_dataframe_attribute():
    for name, struct in lcmschema.types().items():
        for column, _, _ in runs._columns(struct):
            assert not hasattr(pd.DataFrame, column), (name, column)


def test_the_flags_field_is_flag_bits():
    cols = {c: field for c, field, _ in runs._columns(lcmschema.types()["fw_state_t"])}
    assert cols["flag_bits"] == "flags"
    assert "flags" not in cols
