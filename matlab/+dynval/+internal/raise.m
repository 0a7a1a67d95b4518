function raise(kind, message)
%RAISE Throw a dynval input error of one of the contract's six kinds.
%   The kind travels in the identifier ('dynval:InvalidShape', ...) so that callers can
%   switch on it (err.identifier) while the message keeps the contract's exact text.
  error(['dynval:' kind], '%s', message);
end
