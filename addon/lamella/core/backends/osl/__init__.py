"""The OSL emitter: a staged shader printed as straight-line OSL (``emit``) and the bundle a TD
exports with its tables and a README of its inputs (``bundle``)."""
