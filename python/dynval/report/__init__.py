"""validate's report: sections, the assembler, typed records, findings and their words."""
