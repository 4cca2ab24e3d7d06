"""The needle as contact (SPEC section 12): the Hertz check, and the contact cases' study and
report (a contact run's readings and figures are the run's: workflows/run/)."""
