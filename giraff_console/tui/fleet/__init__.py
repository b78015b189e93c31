"""The fleet view (`giraff-console fleet`): every robot on a VDA 5050 broker, and go,
pause, resume, cancel and dock sent to the selected one (issue 28, item 3)."""
