"""The board made of rows: aggregation and ranking, key columns, the registered output formats."""
