"""``vtrack reproduce``: the paper's runs, their figures and the report checking its claims."""
